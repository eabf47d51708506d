"""``--stereo-directions auto`` checks the two projector coordinates against the phase noise,
and the reference plane is the dominant plane (issue 24; docs/stereo.md).

References the code under test did not produce: the virtual rig's ray-cast truth (its own
projection of every camera pixel's surface point), a calibration corrupted by a known shift of
the projector's principal point, and closed-form clouds (a plane under a sphere).
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from hdrfringe.core.stereo import LensModel, StereoCalibration


def _shifted(calib: StereoCalibration, du: float, dv: float) -> StereoCalibration:
    """The calibration with its projector principal point moved by (du, dv) px: the decoded
    columns (rows) then sit du (dv) px off the ones the calibration expects."""
    k = calib.projector.matrix.copy()
    k[0, 2] += du
    k[1, 2] += dv
    lens = LensModel(k, calib.projector.distortion, calib.projector.size)
    return dataclasses.replace(calib, projector=lens)


@pytest.fixture(scope="module")
def virtual():  # type: ignore[no-untyped-def]
    """The virtual rig (mask scene, horizontal baseline) with vertical and horizontal fringes,
    a one-period set each (absolute phase), its true calibration and the ray-cast truth."""
    from hdrfringe.core.patterns import FringeSpec
    from hdrfringe.rig.scenes import mask
    from hdrfringe.rig.simulated import CameraModel, ProjectorModel, SimulatedRig

    rig = SimulatedRig(
        mask(), camera=CameraModel(width=128, height=96),
        projector_model=ProjectorModel(width=256, height=192),
    )  # fmt: skip
    frames = [
        f
        for orient, span in (("vertical", 256.0), ("horizontal", 192.0))
        for pitch in (span, 16.0)
        for f in FringeSpec("sinusoidal", 4, pitch, orient).frames()  # type: ignore[arg-type]
    ]
    caps = rig.capture_folder(frames)
    truth = rig.truth()
    rot, t = rig.geometry.world_to_camera()
    world = np.stack([truth.x_mm, truth.y_mm, truth.height_mm], axis=-1)
    xyz = np.where(truth.valid[..., None], world @ rot.T + t, np.nan)
    return caps, rig.stereo_calibration(), xyz


def _error_mm(xyz: np.ndarray, truth: np.ndarray) -> float:
    """Median distance of the points from the ray-cast truth, mm."""
    err = np.linalg.norm(xyz - truth, axis=-1)
    return float(np.median(err[np.isfinite(err)]))


def test_auto_keeps_both_directions_of_a_good_calibration(virtual) -> None:  # type: ignore[no-untyped-def]
    """The true calibration: the rays miss by what the predicted phase noise says (the ratio
    near 1, measured 1.03; u-only vs v-only 0.97), so u+v is kept. Rejects a check that drops
    a direction of a good rig, and a prediction off by 2x either way."""
    from hdrfringe.pipeline import measure

    caps, calib, truth = virtual
    res = measure(caps, calib)
    check = res.metrics.to_dict()["stereo"]["direction_check"]
    assert res.stereo is not None and res.stereo.directions == ("u", "v")
    assert check["verdict"] == "consistent" and check["directions"] == "u+v"
    assert 0.5 < check["miss_ratio"] < 2.0
    assert 0.5 < check["disagreement_ratio"] < 2.0
    assert check["sigma_source"].startswith("predicted")
    assert _error_mm(res.stereo.xyz, truth) < 0.3  # measured 0.21 (8-bit noise at 1.9 m)


def test_auto_drops_the_rows_of_a_biased_calibration(virtual) -> None:  # type: ignore[no-untyped-def]
    """The projector's principal row moved 3 px: the decoded rows no longer meet the camera
    rays (the baseline is horizontal, so the rows run across the epipolar lines). A row error
    of 3 px explains the miss, a column error would need hundreds: v is dropped and the
    columns alone give the true surface, while u+v would be biased. A column shift moves
    along the epipolar lines: it changes the depth, not the miss, and no check can see it."""
    from hdrfringe.pipeline import measure

    caps, calib, truth = virtual
    bad = _shifted(calib, 0.0, 3.0)
    res = measure(caps, bad)
    check = res.metrics.to_dict()["stereo"]["direction_check"]
    assert check["verdict"] == "v dropped" and check["directions"] == "u"
    assert res.metrics.to_dict()["stereo"]["directions"] == "u"
    assert check["miss_ratio"] > 30  # measured 92
    assert check["error_needed_px"]["v"] == pytest.approx(3.0, abs=0.05)
    forced = measure(caps, bad, stereo_directions="u")
    np.testing.assert_array_equal(res.stereo.xyz, forced.stereo.xyz)  # type: ignore[union-attr]
    assert _error_mm(res.stereo.xyz, truth) < 0.3  # measured 0.21, the good u+v's noise
    # what keeping u+v would have given: ray against ray with the biased rows
    from hdrfringe.core.stereo import projector_coordinate, triangulate_maps

    fams = {f.orientation: f for f in res.decoded.families}
    u, v = (
        projector_coordinate(fams[o].absolute_phase, fams[o].pitch_px)
        for o in ("vertical", "horizontal")
    )
    ray_ray = triangulate_maps(bad, u_proj=u, v_proj=v).xyz
    assert _error_mm(ray_ray, truth) > 3 * _error_mm(res.stereo.xyz, truth)
    # a column shift is invisible to the check (along the epipolar lines)
    assert measure(caps, _shifted(calib, 3.0, 0.0)).stereo.directions == ("u", "v")  # type: ignore[union-attr]


def test_suspect_calibration_is_named_by_the_cli(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """A diagonal baseline (rows and columns both carry depth) with a 2 px row bias: either
    coordinate explains the miss, so neither is dropped; one warning line names the
    calibration as suspect and metrics.json records it. The true calibration prints which
    directions and why, with no warning."""
    from hdrfringe.io.captures import write_capture_folder
    from hdrfringe.io.stereo_file import save_stereo_calibration
    from tests.conftest import run_cli
    from tests.test_stereo import small_calibration, small_captures

    caps = write_capture_folder(tmp_path / "caps", small_captures("uv"))
    good = save_stereo_calibration(tmp_path / "good.h5", small_calibration())
    bad = save_stereo_calibration(tmp_path / "bad.h5", _shifted(small_calibration(), 0.0, 2.0))
    res = run_cli("measure", str(caps), "-c", str(good), "-o", str(tmp_path / "good"))
    assert res.returncode == 0, res.stderr
    lines = [ln for ln in res.stdout.splitlines() if "stereo directions auto" in ln]
    assert len(lines) == 1 and lines[0].startswith("stereo directions auto: u+v (rays miss")
    assert "warning" not in res.stdout
    res = run_cli("measure", str(caps), "-c", str(bad), "-o", str(tmp_path / "bad"))
    assert res.returncode == 0, res.stderr
    warn = [ln for ln in res.stdout.splitlines() if ln.startswith("warning:")]
    assert len(warn) == 1 and "the stereo calibration is suspect" in warn[0]
    assert "triangulated with u+v" in warn[0]
    metrics = json.loads((tmp_path / "bad" / "metrics.json").read_text())
    check = metrics["stereo"]["direction_check"]
    assert check["verdict"] == "suspect" and metrics["stereo"]["directions"] == "u+v"
    assert check["miss_ratio"] > 100


def test_explicit_directions_skip_the_check(virtual) -> None:  # type: ignore[no-untyped-def]
    from hdrfringe.pipeline import measure

    caps, calib, _ = virtual
    summary = measure(caps, _shifted(calib, 0, 3), stereo_directions="v").metrics.to_dict()
    assert summary["stereo"]["directions"] == "v" and "direction_check" not in summary["stereo"]


def test_check_blames_the_direction_along_the_epipolar_lines() -> None:
    """Closed-form pair, vertical baseline (the kimthyung layout: rows carry the depth): a
    column bias is dropped, a row bias is dropped, the noise std scales the ratio."""
    from hdrfringe.core.stereo import check_directions

    cam = LensModel([[400, 0, 31.5], [0, 400, 23.5], [0, 0, 1]], [], (64, 48))
    proj = LensModel([[800, 0, 50], [0, 800, 40], [0, 0, 1]], [], (100, 80))
    calib = StereoCalibration(cam, proj, np.eye(3), [0.0, -100.0, 0])
    rows, cols = np.mgrid[0:48, 0:64].astype(float)
    wall = np.dstack(
        [(cols - 31.5) / 400 * 600, (rows - 23.5) / 400 * 600, np.full(rows.shape, 600.0)]
    )
    u, v = proj.project(wall + calib.translation_mm)
    good = check_directions(calib, u, v, 0.05, 0.05)
    assert good.verdict == "consistent" and good.miss_px < 1e-6
    cols_off = check_directions(calib, u + 2.0, v, 0.05, 0.05)
    assert cols_off.verdict == "u dropped" and cols_off.directions == ("v",)
    assert cols_off.error_needed_px["u"] == pytest.approx(2.0, abs=1e-6)
    # the same 2 px bias is within a noise of 0.5 px: 2 / 0.5 / 0.6745 = 5.9x, kept
    assert check_directions(calib, u + 2.0, v, 0.5, 0.5).verdict == "consistent"
    # a reprojection error of the calibration counts as noise too
    noisy = dataclasses.replace(calib, reprojection_px={"stereo": 0.5})
    assert check_directions(noisy, u + 2.0, v, 0.05, 0.05).verdict == "consistent"


def test_coordinate_noise_px_measures_white_noise_on_a_curved_map() -> None:
    from hdrfringe.core.stereo import coordinate_noise_px

    rng = np.random.default_rng(3)
    r, c = np.mgrid[0:300, 0:400].astype(float)
    smooth = 0.9 * c + 40 * np.sin(r / 60) + 1e-3 * c**2  # gently curved, as a scene's map
    for s in (0.05, 0.3):
        got = coordinate_noise_px(smooth + rng.normal(0, s, smooth.shape))
        assert got == pytest.approx(s, rel=0.05)


def test_dominant_plane_is_not_tilted_by_a_large_sphere() -> None:
    """A tilted wall (0.5 mm noise) a third of which is hidden by a sphere of radius 100 mm
    50 mm in front of it: the robust least-squares fit (MAD refits, an IRLS) runs through the
    sphere's bulk, tilted by 23 degrees with every point an inlier, as kimthyung's was; the
    dominant plane is the wall within 0.05 degrees and its RMS is the noise."""
    from hdrfringe.core.stereo import fit_dominant_plane, fit_plane

    rng = np.random.default_rng(1)
    y, x = np.mgrid[-150:150:1.5, -150:150:1.5]
    normal = np.array([0.35, 0.0, -1.0]) / np.hypot(0.35, 1.0)
    wall = 800 + 0.35 * x
    inside = 100.0**2 - (x - 70) ** 2 - (y - 20) ** 2
    sphere = np.where(inside > 0, 800 + 0.35 * 70 - 50 - np.sqrt(np.clip(inside, 0, None)), np.inf)
    z = np.minimum(wall, sphere) + rng.normal(0, 0.5, x.shape)
    pts = np.dstack([x, y, z])
    assert 0.3 < np.mean(sphere < wall) < 0.35

    def tilt(fit) -> float:  # type: ignore[no-untyped-def]
        return float(np.degrees(np.arccos(min(1.0, abs(fit.normal @ normal)))))

    irls = fit_plane(pts, robust=True)
    assert tilt(irls) > 10 and irls.inliers.mean() > 0.99  # measured 23.0 degrees, all
    fit = fit_dominant_plane(pts)
    assert tilt(fit) < 0.05 and fit.rms_mm == pytest.approx(0.5, rel=0.1)
    on_wall = sphere >= wall
    assert fit.inliers[on_wall].mean() > 0.98 and fit.inliers[~on_wall].mean() < 0.05
