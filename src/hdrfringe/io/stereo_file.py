"""Stereo (projector-camera) calibration files: hdrfringe's HDF5 format and converters.

HDF5 layout (format ``hdrfringe-calibration``, version 1, ``kind = "stereo"``; the
phase-to-height files of :mod:`hdrfringe.io.calibration_file` have no ``kind``)::

    /                    attrs: format, version, kind = "stereo", source,
                                convention = "X_proj = R @ X_cam + t", units = "mm"
    /camera/matrix       (3, 3) float64 intrinsics K, pixels
    /camera/distortion   (n,) float64, OpenCV order (k1, k2, p1, p2[, k3[, k4, k5, k6]])
    /camera              attrs: width, height (pixels)
    /projector/...       the same for the projector (its pattern size)
    /rotation            (3, 3) float64 R
    /translation_mm      (3,) float64 t, mm
    /reprojection_px     attrs: name -> RMS reprojection error, pixels (optional)
    /provenance          attrs and sub-groups: what the writer recorded

As with the phase-to-height files, MATLAB's ``h5read`` returns the 3x3 matrices transposed
(column-major): ``K = h5read(f, '/camera/matrix')'``.

Converters (:func:`convert_calibration`) read OpenCV FileStorage YAML/XML/JSON files, the numpy
``.npz`` layout of thomriiii's ``calibration_dec2025`` and the plain-text matrices of
kimthyung's ``CalibrationData*`` folders; ``docs/stereo.md`` documents every key and mapping.

:func:`load_any_calibration` reads a calibration file of either kind, knowing which from the
file: what a measurement takes (:class:`~hdrfringe.core.calibration.MeasurementCalibration`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from hdrfringe.core._validation import check_regular_file
from hdrfringe.core.calibration import MeasurementCalibration
from hdrfringe.core.stereo import DISTORTION_LENGTHS, LensModel, StereoCalibration
from hdrfringe.errors import InputError, OutputExistsError
from hdrfringe.io.calibration_file import (
    FORMAT_NAME,
    FORMAT_VERSION,
    CalibrationFileError,
    _decode,
    _set_str,
    _write_tree,
    load_calibration,
)

__all__ = [
    "FILESTORAGE_KEYS",
    "KIMTHYUNG_DEFAULTS",
    "KIND",
    "calibration_kind",
    "convert_calibration",
    "load_any_calibration",
    "load_stereo_calibration",
    "save_stereo_calibration",
]

#: Value of the root ``kind`` attribute of a stereo calibration file.
KIND = "stereo"

_UNITS_MM = {"mm": 1.0, "cm": 10.0, "m": 1000.0}


# --------------------------------------------------------------------------------------------
# HDF5: save
# --------------------------------------------------------------------------------------------
def _write(f: Any, calib: StereoCalibration, provenance: Mapping[str, Any]) -> None:
    attrs = f.attrs
    _set_str(attrs, "format", FORMAT_NAME)
    attrs.create("version", np.int64(FORMAT_VERSION))
    _set_str(attrs, "kind", KIND)
    _set_str(attrs, "source", calib.source)
    _set_str(attrs, "convention", "X_proj = R @ X_cam + t")
    _set_str(attrs, "units", "mm")
    for name in ("camera", "projector"):
        lens: LensModel = getattr(calib, name)
        group = f.create_group(name, track_order=True)
        group.attrs.create("width", np.int64(lens.size[0]))
        group.attrs.create("height", np.int64(lens.size[1]))
        ds = group.create_dataset("matrix", data=lens.matrix, dtype=np.float64)
        _set_str(ds.attrs, "description", "[[fx, s, cx], [0, fy, cy], [0, 0, 1]], pixels")
        ds = group.create_dataset("distortion", data=lens.distortion, dtype=np.float64)
        _set_str(ds.attrs, "description", "OpenCV (k1, k2, p1, p2[, k3[, k4, k5, k6]])")
    f.create_dataset("rotation", data=calib.rotation, dtype=np.float64)
    ds = f.create_dataset("translation_mm", data=calib.translation_mm, dtype=np.float64)
    _set_str(ds.attrs, "units", "mm")
    if calib.reprojection_px is not None:
        group = f.create_group("reprojection_px", track_order=True)
        for key, value in calib.reprojection_px.items():
            group.attrs.create(key, np.float64(value))
    _write_tree(f.create_group("provenance", track_order=True), provenance)


def save_stereo_calibration(
    path: str | Path,
    calib: StereoCalibration,
    force: bool = False,
    provenance: Mapping[str, Any] | None = None,
) -> Path:
    """Write a stereo calibration as HDF5, atomically (temporary file, then rename).

    Parameters
    ----------
    path : str or Path
        Target file (conventionally ``*.h5``); parent folders are created.
    calib : StereoCalibration
        The calibration to store (checked by its constructor: finite, a rotation, a baseline).
    force : bool
        Replace an existing file; without it an existing file raises
        :class:`~hdrfringe.errors.OutputExistsError`.
    provenance : mapping, optional
        What to record about the calibration (strings, numbers, lists, nested mappings).

    Returns
    -------
    Path
        The written file.

    Examples
    --------
    >>> import tempfile
    >>> cam = LensModel([[1000, 0, 320], [0, 1000, 240], [0, 0, 1]], [0.1, 0, 0, 0], (640, 480))
    >>> proj = LensModel([[1500, 0, 456], [0, 1500, 570], [0, 0, 1]], [], (912, 1140))
    >>> calib = StereoCalibration(cam, proj, np.eye(3), [-200.0, 0, 0], {"stereo": 0.2}, "doc")
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = save_stereo_calibration(Path(tmp) / "stereo.h5", calib)
    ...     back = load_stereo_calibration(path)
    ...     kind = calibration_kind(path)
    >>> kind, back.baseline_mm, dict(back.reprojection_px), back.projector.size
    ('stereo', 200.0, {'stereo': 0.2}, (912, 1140))
    """
    from hdrfringe.io._hdf5 import save_hdf5

    if not isinstance(calib, StereoCalibration):
        raise InputError(f"expected a StereoCalibration, got {type(calib).__name__}")
    out = Path(path)
    if out.is_dir():
        raise OutputExistsError(f"{out}: is a folder; give a file path for the calibration")
    if out.exists() and not force:
        raise OutputExistsError(
            f"{out}: calibration file exists; pass --force to replace it or choose another path"
        )
    # the same staged writer as the phase-to-height calibration (docs/safety.md): path may be
    # the CheckedOutput of the command's start, and then only the file checked there is replaced
    save_hdf5(path, lambda f: _write(f, calib, dict(provenance or {})), force=force)
    return out


# --------------------------------------------------------------------------------------------
# HDF5: load
# --------------------------------------------------------------------------------------------
def _float_dataset(f: Any, name: str, where: str, shape: tuple[int, ...] | None) -> np.ndarray:
    import h5py

    item = f.get(name)
    if not isinstance(item, h5py.Dataset):
        raise CalibrationFileError(
            f"{where}: dataset /{name} is missing; the file is incomplete, convert or "
            "calibrate again"
        )
    declared = tuple(item.shape or ())
    if (shape is not None and declared != shape) or math.prod(declared) > _MAX_NPZ_ELEMENTS:
        # checked before reading: a few bytes of HDF5 can declare a huge dataset
        raise CalibrationFileError(
            f"{where}: dataset /{name} has shape {declared}, expected "
            f"{shape or 'a few coefficients'}; the file is damaged, convert or calibrate again"
        )
    arr = np.asarray(item[()])
    if arr.dtype.kind not in "fiu":
        raise CalibrationFileError(f"{where}: dataset /{name} is not numeric; the file is damaged")
    arr = arr.astype(np.float64)
    if shape is not None and arr.shape != shape:
        raise CalibrationFileError(
            f"{where}: dataset /{name} has shape {arr.shape}, expected {shape}; the file is "
            "damaged, convert or calibrate again"
        )
    if not np.all(np.isfinite(arr)):
        raise CalibrationFileError(
            f"{where}: dataset /{name} holds NaN or infinite values; the file is damaged"
        )
    return arr


def _read_lens(f: Any, name: str, where: str) -> LensModel:
    import h5py

    group = f.get(name)
    if not isinstance(group, h5py.Group):
        raise CalibrationFileError(f"{where}: group /{name} is missing; the file is incomplete")
    matrix = _float_dataset(f, f"{name}/matrix", where, (3, 3))
    dist = _float_dataset(f, f"{name}/distortion", where, None)
    if dist.ndim != 1 or dist.size not in DISTORTION_LENGTHS:
        raise CalibrationFileError(
            f"{where}: dataset /{name}/distortion has shape {dist.shape}, expected (n,) with n "
            "in 0, 4, 5, 8; the file is damaged"
        )
    size = []
    for key in ("width", "height"):
        if key not in group.attrs:
            raise CalibrationFileError(f"{where}: /{name} has no attribute {key!r}; incomplete")
        size.append(_decode(group.attrs[key]))
    try:
        return LensModel(matrix, dist, (size[0], size[1]))
    except InputError as err:
        raise CalibrationFileError(f"{where}: /{name}: {err}") from None


def _read(f: Any, where: str) -> StereoCalibration:
    import h5py

    attrs = f.attrs
    if "format" not in attrs or _decode(attrs["format"]) != FORMAT_NAME:
        raise CalibrationFileError(
            f"{where}: HDF5 file is not an hdrfringe calibration (no format = {FORMAT_NAME!r} "
            "attribute); give a file written by hdrfringe"
        )
    kind = _decode(attrs["kind"]) if "kind" in attrs else "phase-to-height"
    if kind != KIND:
        raise CalibrationFileError(
            f"{where}: a {kind} calibration, not a stereo one; give a file written by "
            "calibrate-stereo"
        )
    version = _decode(attrs["version"]) if "version" in attrs else None
    if version != FORMAT_VERSION:
        raise CalibrationFileError(
            f"{where}: calibration file version {version} is not supported (this hdrfringe "
            f"reads version {FORMAT_VERSION}); upgrade hdrfringe or convert again"
        )
    camera = _read_lens(f, "camera", where)
    projector = _read_lens(f, "projector", where)
    rotation = _float_dataset(f, "rotation", where, (3, 3))
    translation = _float_dataset(f, "translation_mm", where, (3,))
    errors: dict[str, float] | None = None
    group = f.get("reprojection_px")
    if isinstance(group, h5py.Group):
        errors = {key: float(_decode(group.attrs[key])) for key in group.attrs}
    source = _decode(attrs["source"]) if "source" in attrs else ""
    try:
        return StereoCalibration(camera, projector, rotation, translation, errors, str(source))
    except InputError as err:
        raise CalibrationFileError(f"{where}: {err}") from None


def load_stereo_calibration(path: str | Path) -> StereoCalibration:
    """Read a stereo calibration written by :func:`save_stereo_calibration`.

    Parameters
    ----------
    path : str or Path
        The HDF5 file (format ``hdrfringe-calibration``, version 1, ``kind = "stereo"``).

    Returns
    -------
    StereoCalibration
        The calibration, checked (shapes, finite values, a rotation, a baseline).

    Raises
    ------
    CalibrationFileError
        Missing file, not HDF5, another kind of calibration, a missing dataset or one of the
        wrong shape or with non-finite values; the one-line message names the dataset.

    Examples
    --------
    >>> try:
    ...     load_stereo_calibration("no/such/stereo.h5")
    ... except CalibrationFileError as err:
    ...     print(err)
    no/such/stereo.h5: calibration file not found; check the path
    """
    import h5py

    src = Path(path)
    if not src.is_file():
        if src.exists() and not src.is_dir():  # a FIFO would block h5py forever
            try:
                check_regular_file(src, "calibration file", "check the path")
            except InputError as exc:
                raise CalibrationFileError(str(exc)) from None
        what = (
            "is a folder, not a calibration file" if src.is_dir() else "calibration file not found"
        )
        raise CalibrationFileError(f"{src}: {what}; check the path")
    try:
        f = h5py.File(src, "r")
    except OSError as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise CalibrationFileError(
            f"{src}: not an HDF5 file or corrupt ({reason}); give a file written by hdrfringe"
        ) from None
    try:
        with f:
            return _read(f, str(src))
    except CalibrationFileError:
        raise
    except (KeyError, ValueError, TypeError, OSError, UnicodeDecodeError) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise CalibrationFileError(
            f"{src}: stereo calibration file is damaged ({reason}); convert or calibrate again"
        ) from None


def calibration_kind(path: str | Path) -> str:
    """``"stereo"`` for a stereo calibration file, else ``"phase-to-height"``.

    Anything that is not a readable HDF5 file with ``kind = "stereo"`` is reported as
    ``"phase-to-height"``, whose loader (:func:`hdrfringe.io.calibration_file.load_calibration`)
    then gives its own message for a missing or damaged file.

    Parameters
    ----------
    path : str or Path
        A calibration file.

    Returns
    -------
    str
        ``"stereo"`` or ``"phase-to-height"``.

    Examples
    --------
    >>> calibration_kind("no/such/file.h5")
    'phase-to-height'
    """
    import h5py

    src = Path(path)
    if not src.is_file():
        return "phase-to-height"
    try:
        with h5py.File(src, "r") as f:
            kind = _decode(f.attrs["kind"]) if "kind" in f.attrs else None
    except (OSError, KeyError, TypeError, ValueError, UnicodeDecodeError):
        return "phase-to-height"
    return KIND if kind == KIND else "phase-to-height"


def load_any_calibration(path: str | Path) -> MeasurementCalibration:
    """The calibration in a file, of whichever kind the file holds.

    A stereo calibration file (``kind = "stereo"``, :func:`calibration_kind`) is read by
    :func:`load_stereo_calibration`; anything else by
    :func:`hdrfringe.io.calibration_file.load_calibration`, whose messages then say what is
    wrong with a missing or damaged file.

    Parameters
    ----------
    path : str or Path
        A calibration file written by ``calibrate``, ``calibrate-stereo`` or
        :func:`convert_calibration`.

    Returns
    -------
    MeasurementCalibration
        A :class:`~hdrfringe.core.calibration.Calibration` or a
        :class:`~hdrfringe.core.stereo.StereoCalibration`.

    Raises
    ------
    CalibrationFileError
        Missing file, not HDF5, damaged contents (the one-line message of the kind's loader).

    Examples
    --------
    >>> import tempfile
    >>> cam = LensModel([[1000, 0, 320], [0, 1000, 240], [0, 0, 1]], [], (640, 480))
    >>> proj = LensModel([[1500, 0, 456], [0, 1500, 570], [0, 0, 1]], [], (912, 1140))
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = save_stereo_calibration(
    ...         Path(tmp) / "s.h5", StereoCalibration(cam, proj, np.eye(3), [-200.0, 0, 0]))
    ...     cal = load_any_calibration(path)
    >>> cal.kind, cal.output
    ('stereo', 'points')
    >>> try:
    ...     load_any_calibration("no/such/file.h5")
    ... except CalibrationFileError as err:
    ...     print(err)
    no/such/file.h5: calibration file not found; check the path or calibrate first
    """
    if calibration_kind(path) == KIND:
        return load_stereo_calibration(path)
    return load_calibration(path)


# --------------------------------------------------------------------------------------------
# converters
# --------------------------------------------------------------------------------------------
#: Key names read from an OpenCV FileStorage file (first present wins), by quantity.
#: ``cam_K``... : Moreno & Taubin's procam calibration (``calibration.yml``); ``cam_int``... :
#: kamino410's procam-calibration (``calibration_result.xml``); ``Kc``, ``kc``, ``Kp``, ``kp``,
#: ``Rp``, ``Tp``, ``frameWidth``, ``screenResX``...: SLStudio's ``calibration.xml``;
#: ``K1``, ``D1``...: OpenCV's
#: stereoCalibrate names; ``camera_matrix``, ``distortion_coefficients``: OpenCV's samples.
FILESTORAGE_KEYS: dict[str, tuple[str, ...]] = {
    "camera_matrix": ("cam_K", "cam_int", "camera_matrix", "cameraMatrix", "K1", "M1", "Kc"),
    "camera_distortion": (
        "cam_kc",
        "cam_dist",
        "dist_coeffs",
        "distCoeffs",
        "distortion_coefficients",
        "D1",
        "dist_c",
        "kc",
    ),
    "projector_matrix": ("proj_K", "proj_int", "projector_matrix", "K2", "M2", "Kp"),
    "projector_distortion": (
        "proj_kc",
        "proj_Kc",
        "proj_dist",
        "projector_distortion",
        "D2",
        "dist_p",
        "kp",
    ),
    "rotation": ("R", "rotation", "roration", "Rp"),
    "translation": ("T", "translation", "Tp"),
    "camera_size": ("camera_size", "cam_size", "image_size"),
    "camera_shape": ("img_shape",),
    "camera_width": ("image_width", "cam_width", "camera_width", "frameWidth"),
    "camera_height": ("image_height", "cam_height", "camera_height", "frameHeight"),
    "projector_size": ("projector_size", "proj_size"),
    "projector_width": ("proj_width", "projector_width", "screenResX"),
    "projector_height": ("proj_height", "projector_height", "screenResY"),
    "translation_unit": ("translation_unit", "unit", "units"),
    "error_camera": ("cam_error",),
    "error_projector": ("proj_error",),
    "error_stereo": ("stereo_error", "rms"),
}

#: Facts of kimthyung's rig that its plain-text files do not hold (``../shared/realdata``
#: README): camera 1936x1464; DLP LightCrafter 4500, 912x1140 mirrors, whose diamond pixel
#: array makes the calibration's row unit two pattern rows.
KIMTHYUNG_DEFAULTS: dict[str, Any] = {
    "camera_size": (1936, 1464),
    "projector_size": (912, 1140),
    "projector_row_scale": 2.0,
}


def _shaped(value: Any, name: str, where: str, kind: str) -> np.ndarray:
    """A matrix read from a file, checked and reshaped: kind 'K' (3x3), 'R', 'T', 'D'."""
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise CalibrationFileError(f"{where}: {name!r} is not numeric; check the file") from None
    expected = {"K": "(3, 3)", "R": "(3, 3) or a rotation vector (3,)", "T": "(3,)"}
    if kind == "K":
        ok = arr.shape == (3, 3)
    elif kind == "R" and arr.shape != (3, 3):
        ok = arr.size == 3 and max(arr.shape) == 3
        if ok:
            import cv2

            arr = np.asarray(cv2.Rodrigues(arr.reshape(3, 1))[0], dtype=np.float64)
    elif kind == "T":
        ok = arr.size == 3 and max(arr.shape) == 3
        arr = arr.reshape(3) if ok else arr
    elif kind == "D":
        ok = arr.size in DISTORTION_LENGTHS and arr.size == max(arr.shape, default=0)
        arr = arr.reshape(-1)
        if not ok:
            raise CalibrationFileError(
                f"{where}: {name!r} has shape {arr.shape}; expected 0, 4, 5 or 8 distortion "
                "coefficients (k1, k2, p1, p2[, k3[, k4, k5, k6]]) in one row or column"
            )
    else:
        ok = True
    if not ok:
        raise CalibrationFileError(
            f"{where}: {name!r} has shape {arr.shape}, expected {expected[kind]}; check the file"
        )
    if not np.all(np.isfinite(arr)):
        raise CalibrationFileError(f"{where}: {name!r} holds NaN or infinite values")
    return arr


def _size(value: Any, name: str, where: str) -> tuple[int, int]:
    arr = np.asarray(value, dtype=np.float64).reshape(-1)
    if arr.size != 2 or not np.all(np.isfinite(arr)) or np.any(arr != np.round(arr)):
        raise CalibrationFileError(f"{where}: {name!r} must be two whole numbers, got {value}")
    return int(arr[0]), int(arr[1])


def _build(
    where: str,
    source: str,
    parts: dict[str, Any],
    unit: str,
    errors: dict[str, float] | None,
) -> StereoCalibration:
    if unit not in _UNITS_MM:
        raise CalibrationFileError(
            f"{where}: translation unit {unit!r} unknown; use one of {', '.join(_UNITS_MM)}"
        )
    rotation = np.asarray(parts["R"], dtype=np.float64)
    u, _, vt = np.linalg.svd(rotation)
    nearest = u @ vt
    if np.linalg.det(nearest) > 0 and np.abs(rotation - nearest).max() < 1e-4:
        rotation = nearest  # files rounded to a few decimals: the nearest rotation
    try:
        camera = LensModel(parts["Kc"], parts["Dc"], parts["camera_size"])
        projector = LensModel(parts["Kp"], parts["Dp"], parts["projector_size"])
        return StereoCalibration(
            camera, projector, rotation, parts["T"] * _UNITS_MM[unit], errors, source
        )
    except InputError as err:
        raise CalibrationFileError(f"{where}: {err}") from None


def _from_filestorage(
    path: Path,
    camera_size: tuple[int, int] | None,
    projector_size: tuple[int, int] | None,
    translation_unit: str | None,
) -> StereoCalibration:
    import cv2

    where = str(path)
    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
        opened = fs.isOpened()
    except (cv2.error, SystemError) as exc:  # SystemError: the binding on a parse error
        reason = " ".join(str(exc).split())[-160:]
        raise CalibrationFileError(
            f"{where}: not a readable OpenCV FileStorage file ({reason}); check the file"
        ) from None
    if not opened:
        raise CalibrationFileError(f"{where}: OpenCV cannot open this file; check the path")

    def node(quantity: str) -> tuple[str, Any] | None:
        for key in FILESTORAGE_KEYS[quantity]:
            n = fs.getNode(key)
            if not n.empty() and not n.isNone():
                return key, n
        return None

    def value(quantity: str, required: bool = True) -> tuple[str, Any] | None:
        found = node(quantity)
        if found is None:
            if required:
                raise CalibrationFileError(
                    f"{where}: no {quantity.replace('_', ' ')} (looked for "
                    f"{', '.join(FILESTORAGE_KEYS[quantity])}); add it to the file"
                )
            return None
        key, n = found
        if n.isMap():
            out = n.mat()
        elif n.isSeq():
            out = [n.at(i).real() for i in range(n.size())]
        elif n.isString():
            out = n.string()
        else:
            out = n.real()
        return key, out

    try:
        parts: dict[str, Any] = {}
        for quantity, short, kind in (
            ("camera_matrix", "Kc", "K"),
            ("camera_distortion", "Dc", "D"),
            ("projector_matrix", "Kp", "K"),
            ("projector_distortion", "Dp", "D"),
            ("rotation", "R", "R"),
            ("translation", "T", "T"),
        ):
            found = value(quantity, required=quantity not in ("camera_distortion",))
            if found is None:
                parts[short] = np.zeros(0)
                continue
            parts[short] = _shaped(found[1], found[0], where, kind)
        for lens, override in (("camera", camera_size), ("projector", projector_size)):
            if override is not None:
                parts[f"{lens}_size"] = override
                continue
            pair = value(f"{lens}_size", required=False)
            if pair is not None:
                parts[f"{lens}_size"] = _size(pair[1], pair[0], where)
                continue
            if lens == "camera":
                shape = value("camera_shape", required=False)
                if shape is not None:
                    rows, cols = _size(shape[1], shape[0], where)
                    parts["camera_size"] = (cols, rows)
                    continue
            w, h = value(f"{lens}_width", required=False), value(f"{lens}_height", required=False)
            if w is None or h is None:
                raise CalibrationFileError(
                    f"{where}: no {lens} image size; add {FILESTORAGE_KEYS[f'{lens}_width'][0]} "
                    f"and {FILESTORAGE_KEYS[f'{lens}_height'][0]} (pixels) to the file"
                )
            parts[f"{lens}_size"] = _size([w[1], h[1]], f"{w[0]}/{h[0]}", where)
        unit = translation_unit
        if unit is None:
            found = value("translation_unit", required=False)
            unit = str(found[1]).strip() if found is not None else "mm"
        errors: dict[str, float] = {}
        for name in ("camera", "projector", "stereo"):
            found = value(f"error_{name}", required=False)
            if found is not None and isinstance(found[1], float):
                errors[name] = found[1]
    finally:
        fs.release()
    return _build(where, f"OpenCV FileStorage {path.name}", parts, unit, errors or None)


#: Elements of one array of a stereo calibration file (.npz member, HDF5 dataset): its
#: matrices are 3x3, its distortion vectors at most 14 long, its sizes and errors scalars.
_MAX_NPZ_ELEMENTS = 4096


def _npz_shape(z: Any, key: str) -> tuple[int, ...]:
    """The shape a .npz member declares in its .npy header, read without its data."""
    from numpy.lib import format as npy

    with z.zip.open(f"{key}.npy") as fh:
        version = npy.read_magic(fh)
        read_header = {(1, 0): npy.read_array_header_1_0, (2, 0): npy.read_array_header_2_0}
        if version not in read_header:
            raise ValueError(f"member {key!r}: .npy format version {version} is not read here")
        shape, _, _ = read_header[version](fh)
    return tuple(shape)


def _npz(path: Path, where: str) -> dict[str, np.ndarray]:
    try:
        check_regular_file(path, "calibration file", "give the stereo_params.npz file")
    except InputError as exc:
        raise CalibrationFileError(str(exc)) from None
    try:
        with np.load(path, allow_pickle=False) as z:
            for key in z.files:  # before any is read: a small file can declare a huge array
                shape = _npz_shape(z, key)
                if math.prod(shape) > _MAX_NPZ_ELEMENTS:
                    raise CalibrationFileError(
                        f"{where}: array {key!r} declares shape {'x'.join(map(str, shape))}, "
                        f"more than {_MAX_NPZ_ELEMENTS} values; a stereo calibration holds "
                        "3x3 matrices and short vectors, give the calibration's own .npz"
                    )
            return {k: np.asarray(z[k]) for k in z.files}
    except (OSError, ValueError, EOFError, KeyError) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise CalibrationFileError(f"{where}: not a readable .npz file ({reason})") from None


def _from_npz(
    path: Path,
    camera_size: tuple[int, int] | None,
    projector_size: tuple[int, int] | None,
    translation_unit: str | None,
) -> StereoCalibration:
    """thomriiii's layout: stereo_params.npz (+ camera_ and projector_intrinsics.npz)."""
    folder = path if path.is_dir() else path.parent
    main = folder / "stereo_params.npz" if path.is_dir() else path
    where = str(main)
    if not main.is_file():
        raise CalibrationFileError(f"{where}: not found; give the stereo_params.npz file")
    data = _npz(main, where)
    cam_file, proj_file = folder / "camera_intrinsics.npz", folder / "projector_intrinsics.npz"
    cam = _npz(cam_file, str(cam_file)) if cam_file.is_file() else {}
    proj = _npz(proj_file, str(proj_file)) if proj_file.is_file() else {}
    missing = [k for k in ("Kc", "dist_c", "Kp", "dist_p", "R", "T") if k not in data]
    if missing:
        raise CalibrationFileError(
            f"{where}: keys {', '.join(missing)} missing (thomriiii layout: Kc, dist_c, Kp, "
            "dist_p, R, T); give stereo_params.npz of a calibration_dec2025-style folder"
        )
    # The layout's R, T map projector to camera coordinates, X_cam = R X_proj + T (measured on
    # the checkerboard scan, docs/stereo.md): invert them to X_proj = R.T X_cam - R.T T.
    r_pc, t_pc = _shaped(data["R"], "R", where, "R"), _shaped(data["T"], "T", where, "T")
    parts: dict[str, Any] = {
        "Kc": _shaped(data["Kc"], "Kc", where, "K"),
        "Dc": _shaped(data["dist_c"], "dist_c", where, "D"),
        "Kp": _shaped(data["Kp"], "Kp", where, "K"),
        "Dp": _shaped(data["dist_p"], "dist_p", where, "D"),
        "R": r_pc.T,
        "T": -r_pc.T @ t_pc,
    }
    for lens, key, extra, override in (
        ("camera", "image_size", cam, camera_size),
        ("projector", "image_size_proj", proj, projector_size),
    ):
        if override is not None:
            parts[f"{lens}_size"] = override
        elif key in data:
            parts[f"{lens}_size"] = _size(data[key], key, where)
        elif key in extra:
            parts[f"{lens}_size"] = _size(extra[key], key, str(folder / f"{lens}_intrinsics.npz"))
        else:
            raise CalibrationFileError(
                f"{where}: no {lens} size ({key!r} here or in {lens}_intrinsics.npz beside it); "
                f"give {lens}_size"
            )
    errors = {}
    for name, source in (("camera", cam), ("projector", proj), ("stereo", data)):
        if "rms" in source and np.asarray(source["rms"]).size == 1:
            errors[name] = float(np.asarray(source["rms"]).reshape(-1)[0])
    unit = translation_unit or "m"  # the layout's unit: metres (docs/stereo.md)
    return _build(where, f"thomriiii npz {main.name}", parts, unit, errors or None)


def _text_matrix(path: Path) -> np.ndarray:
    if not path.is_file():
        raise CalibrationFileError(f"{path}: missing; the CalibrationData folder is incomplete")
    try:
        return np.loadtxt(path, dtype=np.float64, ndmin=2)
    except ValueError as exc:
        raise CalibrationFileError(f"{path}: not a matrix of numbers ({exc})") from None


def _from_kimthyung(
    folder: Path,
    camera_size: tuple[int, int] | None,
    projector_size: tuple[int, int] | None,
    translation_unit: str | None,
    projector_row_scale: float | None,
) -> StereoCalibration:
    """kimthyung's CalibrationData* folder of plain-text matrices."""

    def read(name: str, kind: str) -> np.ndarray:
        p = folder / name
        return _shaped(_text_matrix(p), p.name, str(p), kind)

    kc, dc = (
        read("CamIntrinsicMatrixRight.txt", "K"),
        read("CamDistortionCoefficientsRight.txt", "D"),
    )
    kp, dp = read("ProjIntrinsicMatrix.txt", "K"), read("ProjDistortionCoefficients.txt", "D")
    rp, tp = read("ProjRotationMatrix.txt", "R"), read("ProjTranslationVector.txt", "T")
    rc, tc = np.eye(3), np.zeros(3)
    if (folder / "CamRotationMatrixRight.txt").exists():
        rc = read("CamRotationMatrixRight.txt", "R")
    if (folder / "CamTranslationVectorRight.txt").exists():
        tc = read("CamTranslationVectorRight.txt", "T")
    # world -> camera X_c = Rc X_w + Tc, world -> projector X_p = Rp X_w + Tp
    rotation = rp @ rc.T
    translation = tp - rotation @ tc
    scale = float(
        KIMTHYUNG_DEFAULTS["projector_row_scale"]
        if projector_row_scale is None
        else projector_row_scale
    )
    if not (np.isfinite(scale) and scale > 0):
        raise CalibrationFileError(f"{folder}: projector_row_scale must be > 0, got {scale}")
    kp = kp.copy()
    kp[1, 1:] *= scale  # calibration rows -> pattern rows: v_pattern = scale * v_calibration
    parts = {
        "Kc": kc,
        "Dc": dc,
        "Kp": kp,
        "Dp": dp,
        "R": rotation,
        "T": translation,
        "camera_size": camera_size or KIMTHYUNG_DEFAULTS["camera_size"],
        "projector_size": projector_size or KIMTHYUNG_DEFAULTS["projector_size"],
    }
    return _build(str(folder), f"kimthyung {folder.name}", parts, translation_unit or "mm", None)


def convert_calibration(
    path: str | Path,
    *,
    camera_size: tuple[int, int] | None = None,
    projector_size: tuple[int, int] | None = None,
    translation_unit: str | None = None,
    projector_row_scale: float | None = None,
) -> StereoCalibration:
    """Read a projector-camera calibration written by another tool.

    Parameters
    ----------
    path : str or Path
        One of (``docs/stereo.md`` lists every key and mapping):

        - an OpenCV FileStorage file (``.yml``, ``.yaml``, ``.xml``, ``.json``) with the keys
          of :data:`FILESTORAGE_KEYS` (e.g. ``cam_K``, ``cam_kc``, ``proj_K``, ``proj_kc``,
          ``R``, ``T`` of a stereoCalibrate-based tool);
        - a ``.npz`` file or a folder of thomriiii's ``calibration_dec2025`` layout
          (``stereo_params.npz`` + ``camera_intrinsics.npz`` + ``projector_intrinsics.npz``;
          its ``R``, ``T`` map projector to camera coordinates, translation in metres);
        - a folder of kimthyung's plain-text matrices (``ProjIntrinsicMatrix.txt``, ...);
        - an hdrfringe stereo calibration (``.h5``), read as is.
    camera_size, projector_size : (int, int), optional
        ``(width, height)`` in pixels where the file has none (or to override it).
    translation_unit : {"mm", "cm", "m"}, optional
        Unit of the file's translation, where the file does not say: default ``"mm"`` for
        FileStorage and plain text, ``"m"`` for the thomriiii layout.
    projector_row_scale : float, optional
        Plain-text layout only: pattern rows per calibration row (default 2, the DLP4500's
        diamond pixel array; see :data:`KIMTHYUNG_DEFAULTS`).

    Returns
    -------
    StereoCalibration
        In hdrfringe's conventions: ``X_proj = R @ X_cam + t`` in mm, projector pixels of the
        projected pattern.

    Raises
    ------
    CalibrationFileError
        Unknown layout, a missing key or file, a matrix of the wrong shape, non-finite values,
        or values that are no calibration (e.g. R not a rotation); one line naming the key.

    Examples
    --------
    >>> import tempfile, cv2
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = Path(tmp) / "calibration.yml"
    ...     fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    ...     fs.write("cam_K", np.array([[1000.0, 0, 320], [0, 1000, 240], [0, 0, 1]]))
    ...     fs.write("cam_kc", np.zeros((1, 5)))
    ...     fs.write("proj_K", np.array([[1500.0, 0, 456], [0, 1500, 570], [0, 0, 1]]))
    ...     fs.write("proj_kc", np.zeros((1, 5)))
    ...     fs.write("R", np.eye(3))
    ...     fs.write("T", np.array([[-150.0], [0], [0]]))
    ...     fs.write("stereo_error", 0.25)
    ...     fs.write("image_width", 640); fs.write("image_height", 480)
    ...     fs.write("proj_width", 912); fs.write("proj_height", 1140)
    ...     fs.release()
    ...     calib = convert_calibration(path)
    >>> calib.baseline_mm, calib.camera.size, dict(calib.reprojection_px)
    (150.0, (640, 480), {'stereo': 0.25})
    """
    src = Path(path)
    if not src.exists():
        raise CalibrationFileError(f"{src}: not found; give a calibration file or folder")
    if not src.is_dir():  # a FIFO would block the reader forever
        try:
            check_regular_file(src, "calibration file", "give a calibration file or folder")
        except InputError as exc:
            raise CalibrationFileError(str(exc)) from None
    for name, size in (("camera_size", camera_size), ("projector_size", projector_size)):
        if size is not None:
            _size(size, name, str(src))
    if src.is_dir():
        if (src / "stereo_params.npz").is_file():
            return _from_npz(src, camera_size, projector_size, translation_unit)
        if (src / "ProjIntrinsicMatrix.txt").is_file():
            return _from_kimthyung(
                src, camera_size, projector_size, translation_unit, projector_row_scale
            )
        raise CalibrationFileError(
            f"{src}: a folder with neither stereo_params.npz nor ProjIntrinsicMatrix.txt; give "
            "a calibration file (.yml, .xml, .json, .npz, .h5) or a known calibration folder"
        )
    suffix = src.suffix.lower()
    if suffix in (".yml", ".yaml", ".xml", ".json", ".gz"):
        return _from_filestorage(src, camera_size, projector_size, translation_unit)
    if suffix == ".npz":
        return _from_npz(src, camera_size, projector_size, translation_unit)
    if suffix in (".h5", ".hdf5"):
        return load_stereo_calibration(src)
    raise CalibrationFileError(
        f"{src}: unknown calibration format {suffix or '(no extension)'!r}; give an OpenCV "
        "FileStorage file (.yml, .yaml, .xml, .json), a thomriiii .npz or a known folder"
    )
