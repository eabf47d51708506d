"""Stereo calibration files (issue 12, point 5): hdrfringe's HDF5 format and the converters.

References: values written by OpenCV's own FileStorage writer, by numpy and as plain text, then
read back and compared with what was written (independent of the converter's code).
"""

from __future__ import annotations

from pathlib import Path

import cv2
import h5py
import numpy as np
import pytest

from hdrfringe.core.stereo import LensModel, StereoCalibration
from hdrfringe.errors import OutputExistsError
from hdrfringe.io.calibration_file import CalibrationFileError, load_calibration
from hdrfringe.io.stereo_file import (
    calibration_kind,
    convert_calibration,
    load_stereo_calibration,
    save_stereo_calibration,
)

KC = np.array([[2400.0, 0.0, 1010.0], [0.0, 2390.0, 770.0], [0.0, 0.0, 1.0]])
DC = np.array([-0.25, 0.18, 0.0012, -0.0008, -0.05])
KP = np.array([[1800.0, 0.0, 460.0], [0.0, 3600.0, 1130.0], [0.0, 0.0, 1.0]])
DP = np.array([0.12, -0.3, 0.002, 0.001])
R = cv2.Rodrigues(np.array([0.02, 0.3, 0.01]))[0]
T = np.array([-240.0, 20.0, 45.0])


def calibration() -> StereoCalibration:
    return StereoCalibration(
        LensModel(KC, DC, (2048, 1536)),
        LensModel(KP, DP, (912, 1140)),
        R,
        T,
        {"camera": 0.11, "projector": 0.2, "stereo": 0.15},
        "test",
    )


def assert_same(a: StereoCalibration, b: StereoCalibration, rtol: float = 0.0) -> None:
    for name in ("camera", "projector"):
        la, lb = getattr(a, name), getattr(b, name)
        np.testing.assert_allclose(la.matrix, lb.matrix, rtol=rtol)
        np.testing.assert_allclose(la.distortion, lb.distortion, rtol=rtol)
        assert la.size == lb.size
    np.testing.assert_allclose(a.rotation, b.rotation, rtol=rtol, atol=1e-15 if rtol else 0)
    np.testing.assert_allclose(a.translation_mm, b.translation_mm, rtol=rtol)


# --- HDF5 -------------------------------------------------------------------------------------


def test_hdf5_round_trip_is_exact(tmp_path: Path) -> None:
    path = save_stereo_calibration(tmp_path / "s.h5", calibration(), provenance={"by": "test"})
    back = load_stereo_calibration(path)
    assert_same(back, calibration())
    assert dict(back.reprojection_px or {}) == {"camera": 0.11, "projector": 0.2, "stereo": 0.15}
    assert back.source == "test" and calibration_kind(path) == "stereo"
    with h5py.File(path) as f:  # the layout of docs/stereo.md, read without hdrfringe
        assert f.attrs["kind"] == b"stereo" or f.attrs["kind"] == "stereo"
        np.testing.assert_array_equal(f["projector/matrix"][()], KP)
        np.testing.assert_array_equal(f["translation_mm"][()], T)
        assert int(f["camera"].attrs["width"]) == 2048
    with pytest.raises(OutputExistsError, match="exists"):
        save_stereo_calibration(path, calibration())
    save_stereo_calibration(path, calibration(), force=True)


def test_phase_to_height_loader_refuses_a_stereo_file(tmp_path: Path) -> None:
    path = save_stereo_calibration(tmp_path / "s.h5", calibration())
    with pytest.raises(CalibrationFileError, match="a stereo calibration, not a phase-to-height"):
        load_calibration(path)


@pytest.mark.parametrize(
    ("dataset", "value", "match"),
    [
        ("camera/matrix", np.eye(2), r"/camera/matrix has shape \(2, 2\), expected \(3, 3\)"),
        ("rotation", np.full((3, 3), np.nan), "/rotation holds NaN"),
        ("translation_mm", np.zeros((3, 1)), r"/translation_mm has shape \(3, 1\)"),
        ("projector/distortion", np.zeros(3), r"/projector/distortion has shape \(3,\)"),
        ("rotation", 2 * np.eye(3), "not a rotation"),
        ("projector/matrix", None, "/projector/matrix is missing"),
    ],
)
def test_hdf5_damaged_datasets_give_one_line_errors(
    tmp_path: Path, dataset: str, value: np.ndarray | None, match: str
) -> None:
    path = save_stereo_calibration(tmp_path / "s.h5", calibration())
    with h5py.File(path, "a") as f:
        del f[dataset]
        if value is not None:
            f.create_dataset(dataset, data=value)
    with pytest.raises(CalibrationFileError, match=match) as err:
        load_stereo_calibration(path)
    assert "\n" not in str(err.value) and str(path) in str(err.value)


def test_stereo_loader_refuses_other_files(tmp_path: Path) -> None:
    (tmp_path / "x.h5").write_bytes(b"not hdf5")
    with pytest.raises(CalibrationFileError, match="not an HDF5 file"):
        load_stereo_calibration(tmp_path / "x.h5")
    with h5py.File(tmp_path / "k.h5", "w") as f:
        f.attrs["format"] = "hdrfringe-calibration"
        f.attrs["version"] = 1
    with pytest.raises(CalibrationFileError, match="phase-to-height calibration, not a stereo"):
        load_stereo_calibration(tmp_path / "k.h5")
    assert calibration_kind(tmp_path / "k.h5") == "phase-to-height"
    assert calibration_kind(tmp_path / "x.h5") == "phase-to-height"


# --- converters -------------------------------------------------------------------------------


def _write_filestorage(path: Path, entries: dict[str, object]) -> Path:
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    for key, value in entries.items():
        fs.write(key, value)
    fs.release()
    return path


@pytest.mark.parametrize("suffix", [".yml", ".xml", ".json"])
def test_filestorage_moreno_taubin_keys(tmp_path: Path, suffix: str) -> None:
    path = _write_filestorage(
        tmp_path / f"calibration{suffix}",
        {
            "cam_K": KC,
            "cam_kc": DC.reshape(1, 5),
            "proj_K": KP,
            "proj_kc": DP.reshape(4, 1),
            "R": R,
            "T": T.reshape(3, 1),
            "cam_error": 0.11,
            "proj_error": 0.2,
            "stereo_error": 0.15,
            "image_width": 2048,
            "image_height": 1536,
            "proj_width": 912,
            "proj_height": 1140,
        },
    )
    got = convert_calibration(path)
    assert_same(got, calibration(), rtol=1e-15)
    assert dict(got.reprojection_px or {}) == pytest.approx(
        {"camera": 0.11, "projector": 0.2, "stereo": 0.15}
    )


def test_filestorage_kamino410_keys_metres_and_rotation_vector(tmp_path: Path) -> None:
    rvec = cv2.Rodrigues(R)[0]
    path = _write_filestorage(
        tmp_path / "calibration_result.xml",
        {
            "img_shape": (1536, 2048),  # numpy (rows, cols) of the camera image
            "rms": 0.15,
            "cam_int": KC,
            "cam_dist": DC.reshape(1, 5),
            "proj_int": KP,
            "proj_dist": DP.reshape(1, 4),
            "rotation": rvec,
            "translation": T.reshape(3, 1) / 1000.0,
            "translation_unit": "m",
            "projector_size": (912, 1140),
        },
    )
    got = convert_calibration(path)
    assert_same(got, calibration(), rtol=1e-12)
    assert got.camera.size == (2048, 1536)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"cam_K": np.eye(2)}, r"'cam_K' has shape \(2, 2\), expected \(3, 3\)"),
        ({"T": np.zeros((2, 2))}, r"'T' has shape \(2, 2\), expected \(3,\)"),
        ({"proj_kc": np.zeros((1, 6))}, r"'proj_kc' has shape \(6,\); expected 0, 4, 5 or 8"),
        ({"R": np.zeros((3, 4))}, r"'R' has shape \(3, 4\)"),
        ({"R": np.diag([1.0, 1.0, -1.0])}, "not a rotation"),
        ({"proj_width": None}, "no projector image size; add proj_width and proj_height"),
        ({"proj_K": None}, "no projector matrix"),
        ({"translation_unit": "inch"}, "translation unit 'inch' unknown"),
    ],
)
def test_filestorage_bad_content_gives_one_line_errors(
    tmp_path: Path, change: dict[str, object], match: str
) -> None:
    entries: dict[str, object] = {
        "cam_K": KC,
        "cam_kc": DC.reshape(1, 5),
        "proj_K": KP,
        "proj_kc": DP.reshape(1, 4),
        "R": R,
        "T": T.reshape(3, 1),
        "image_width": 2048,
        "image_height": 1536,
        "proj_width": 912,
        "proj_height": 1140,
    }
    entries.update(change)
    path = _write_filestorage(
        tmp_path / "c.yml", {k: v for k, v in entries.items() if v is not None}
    )
    with pytest.raises(CalibrationFileError, match=match) as err:
        convert_calibration(path)
    assert "\n" not in str(err.value)


def test_unknown_and_unreadable_inputs(tmp_path: Path) -> None:
    (tmp_path / "c.txt").write_text("1 2 3")
    with pytest.raises(CalibrationFileError, match=r"unknown calibration format '\.txt'"):
        convert_calibration(tmp_path / "c.txt")
    (tmp_path / "broken.yml").write_text("%YAML:1.0\ncam_K: [1, 2\n")
    with pytest.raises(CalibrationFileError, match=r"broken\.yml") as err:
        convert_calibration(tmp_path / "broken.yml")
    assert "\n" not in str(err.value)
    with pytest.raises(CalibrationFileError, match=r"neither stereo_params\.npz"):
        convert_calibration(tmp_path)
    with pytest.raises(CalibrationFileError, match="not found"):
        convert_calibration(tmp_path / "missing.yml")


def test_npz_layout_of_thomriiii(tmp_path: Path) -> None:
    """stereo_params.npz (projector -> camera, T in metres) + the two intrinsics files."""
    np.savez(
        tmp_path / "stereo_params.npz",
        R=R.T,  # X_cam = R.T X_proj - R.T T
        T=(-R.T @ T).reshape(3, 1) / 1000.0,
        Kc=KC,
        dist_c=DC.reshape(1, 5),
        Kp=KP,
        dist_p=DP.reshape(1, 4),
        rms=np.array([0.15], np.float32),
    )
    np.savez(tmp_path / "camera_intrinsics.npz", K=KC, image_size=np.array([2048, 1536]))
    np.savez(
        tmp_path / "projector_intrinsics.npz",
        Kp=KP,
        image_size_proj=np.array([912, 1140], np.int32),
        rms=np.array([0.2], np.float32),
    )
    for path in (tmp_path, tmp_path / "stereo_params.npz"):
        got = convert_calibration(path)
        assert_same(got, calibration(), rtol=1e-12)
        assert set(got.reprojection_px or {}) == {"projector", "stereo"}
    np.savez(tmp_path / "stereo_params.npz", R=R, T=T, Kc=KC, dist_c=DC, Kp=np.eye(3)[:2])
    with pytest.raises(CalibrationFileError, match="keys dist_p missing"):
        convert_calibration(tmp_path)


def test_plain_text_layout_of_kimthyung(tmp_path: Path) -> None:
    """World = a board frame; camera rows unit 1, projector rows unit 2 (DLP4500)."""
    rc = cv2.Rodrigues(np.array([0.1, -0.2, 0.05]))[0]
    tc = np.array([10.0, -20.0, 600.0])
    # world -> projector such that X_p = R X_c + T with the test's R, T
    rp, tp = R @ rc, R @ tc + T
    kp_calibration = KP.copy()
    kp_calibration[1, 1:] /= 2.0  # the file's row unit is two pattern rows
    for name, value in {
        "CamIntrinsicMatrixRight.txt": KC,
        "CamDistortionCoefficientsRight.txt": DC.reshape(5, 1),
        "CamRotationMatrixRight.txt": rc,
        "CamTranslationVectorRight.txt": tc.reshape(3, 1),
        "ProjIntrinsicMatrix.txt": kp_calibration,
        "ProjDistortionCoefficients.txt": DP.reshape(4, 1),
        "ProjRotationMatrix.txt": rp,
        "ProjTranslationVector.txt": tp.reshape(3, 1),
    }.items():
        np.savetxt(tmp_path / name, value, fmt="%.17g", delimiter="\t")
    got = convert_calibration(tmp_path, camera_size=(2048, 1536))
    assert_same(got, calibration(), rtol=1e-9)
    assert got.projector.size == (912, 1140)  # the DLP4500 default
    # a projector point: the file's own model (rows in calibration units) gives v / 2
    pt = np.array([[30.0, -12.0, 650.0]])  # camera frame
    world = (pt - tc) @ rc  # rc.T (X_c - tc)
    v_file = cv2.projectPoints(world, cv2.Rodrigues(rp)[0], tp, kp_calibration, DP)[0][0, 0, 1]
    _, v_ours = got.projector.project(pt @ got.rotation.T + got.translation_mm)
    assert float(v_ours[0]) == pytest.approx(2 * v_file, abs=1e-9)
    np.savetxt(tmp_path / "ProjIntrinsicMatrix.txt", np.eye(3)[:2])
    with pytest.raises(CalibrationFileError, match=r"ProjIntrinsicMatrix.txt' has shape \(2, 3\)"):
        convert_calibration(tmp_path)


def test_h5_input_is_read_as_is(tmp_path: Path) -> None:
    path = save_stereo_calibration(tmp_path / "s.h5", calibration())
    assert_same(convert_calibration(path), calibration())
