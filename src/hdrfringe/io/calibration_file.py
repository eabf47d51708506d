"""Calibration files: HDF5 readable from MATLAB, written atomically, checked on use.

Layout (format ``hdrfringe-calibration``, version 1; see ``docs/calibration.md``)::

    /                         attrs: format, version, model, filter_window_px, border_px,
                                     image_height, image_width, n_positions,
                                     [camera_bit_depth], [gamma_precompensation]
    /k_map                    (H, W) float64, mm/rad, filtered linear K (Eq. 2.15)
    /reference_phase          (H, W) float64, rad
    /depths_mm                (J,) float64
    /coefficients             (M, H, W) float64, only for non-linear models
    /residual_rms_mm/<model>            (H, W) float32, with the filtered maps
    /residual_rms_unfiltered_mm/<model> (H, W) float32
    /spec                     attrs: pattern, steps, pitch_px, orientation, imin, migl
    /provenance               attrs and sub-groups: whatever the caller recorded

Only plain numeric datasets and attributes and fixed-length UTF-8 string attributes are used
(no compound types, references or variable-length strings), so MATLAB's ``h5read`` and
``h5readatt`` read everything. MATLAB is column-major: an (H, W) dataset arrives as W x H and an
(M, H, W) one as W x H x M; ``permute(x, [2 1])`` / ``permute(c, [3 2 1])`` restore the order.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from hdrfringe.core._validation import check_regular_file
from hdrfringe.core.calibration import MODELS, N_COEFFICIENTS, Calibration, check_calibration
from hdrfringe.core.limits import MAX_IMAGE_PIXELS, MAX_PROGRAM_FRAMES
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import HdrFringeError, InputError, OutputExistsError

__all__ = [
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "CalibrationFileError",
    "coefficient_names",
    "load_calibration",
    "save_calibration",
]

#: Value of the root ``format`` attribute of every calibration file.
FORMAT_NAME = "hdrfringe-calibration"
#: Layout version written, and the only one read.
FORMAT_VERSION = 1

_COEFFICIENT_NAMES = {
    "rational": ("a", "b"),
    "poly2": ("c1", "c2"),
    "poly3": ("c1", "c2", "c3"),
}
_EQUATIONS = {
    "linear": "h = K .* dphi",
    "rational": "h = dphi ./ (a + b .* dphi)",
    "poly2": "h = c1 .* dphi + c2 .* dphi.^2",
    "poly3": "h = c1 .* dphi + c2 .* dphi.^2 + c3 .* dphi.^3",
}
_RESIDUAL_GROUPS = ("residual_rms_mm", "residual_rms_unfiltered_mm")
_COMPRESSION: dict[str, Any] = {"compression": "gzip", "compression_opts": 4}


class CalibrationFileError(HdrFringeError):
    """A calibration file is missing, unreadable, foreign, of another version or incomplete.

    Raised by :func:`load_calibration`; the message names the file and what to do.

    Examples
    --------
    >>> try:
    ...     load_calibration("no/such/calibration.h5")
    ... except CalibrationFileError as err:
    ...     print(err)
    no/such/calibration.h5: calibration file not found; check the path or calibrate first
    """


# --------------------------------------------------------------------------------------------
# attribute helpers (fixed-length UTF-8 strings, plain numbers)
# --------------------------------------------------------------------------------------------
def _set_str(attrs: Any, name: str, value: str) -> None:
    import h5py

    raw = value.encode("utf-8")
    n = max(1, len(raw))
    attrs.create(name, np.array(raw, dtype=f"S{n}"), dtype=h5py.string_dtype("utf-8", n))


def _set_str_list(attrs: Any, name: str, values: list[str]) -> None:
    import h5py

    raw = [v.encode("utf-8") for v in values]
    n = max([1, *(len(r) for r in raw)])
    attrs.create(name, np.array(raw, dtype=f"S{n}"), dtype=h5py.string_dtype("utf-8", n))


def _get(attrs: Any, name: str, where: str) -> Any:
    if name not in attrs:
        raise CalibrationFileError(
            f"{where}: attribute {name!r} is missing; the file is incomplete, recalibrate"
        )
    return _decode(attrs[name])


def _decode(value: Any) -> Any:
    """HDF5 attribute value -> Python str, int, float or list of those."""
    if isinstance(value, (bytes, np.bytes_)):
        return bytes(value).decode("utf-8")
    if isinstance(value, str):
        return value
    if isinstance(value, np.ndarray):
        if value.ndim == 0:
            return _decode(value[()])
        return [_decode(v) for v in value.tolist()]
    if isinstance(value, (np.integer, int)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        return float(value)
    raise TypeError(f"unsupported attribute type {type(value).__name__}")


def _write_tree(group: Any, tree: Mapping[str, Any]) -> None:
    """Provenance dict -> attributes (str, numbers, lists) and sub-groups (dicts)."""
    for key, value in tree.items():
        if isinstance(value, Mapping):
            _write_tree(group.create_group(key, track_order=True), value)
        elif isinstance(value, str):
            _set_str(group.attrs, key, value)
        elif isinstance(value, (list, tuple)):
            if value and all(isinstance(v, str) for v in value):
                _set_str_list(group.attrs, key, list(value))
            elif all(isinstance(v, int) for v in value) and value:
                group.attrs.create(key, np.asarray(value, dtype=np.int64))
            else:
                group.attrs.create(key, np.asarray(value, dtype=np.float64))
        elif isinstance(value, int):
            group.attrs.create(key, np.int64(value))
        else:
            group.attrs.create(key, np.float64(value))


def _read_tree(group: Any) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key in group.attrs:
        out[key] = _decode(group.attrs[key])
    for key, item in group.items():
        out[key] = _read_tree(item) if hasattr(item, "keys") else _decode(item[()])
    return out


# --------------------------------------------------------------------------------------------
# save
# --------------------------------------------------------------------------------------------
def _write(f: Any, cal: Calibration) -> None:
    attrs = f.attrs
    _set_str(attrs, "format", FORMAT_NAME)
    attrs.create("version", np.int64(FORMAT_VERSION))
    _set_str(attrs, "model", cal.model)
    _set_str(attrs, "equation", _EQUATIONS[cal.model])
    attrs.create("filter_window_px", np.int64(cal.filter_window_px))
    attrs.create("border_px", np.int64(cal.border_px))
    shape = cal.image_shape
    assert shape is not None, "Calibration.__post_init__ sets image_shape"
    height, width = shape
    attrs.create("image_height", np.int64(height))
    attrs.create("image_width", np.int64(width))
    attrs.create("n_positions", np.int64(cal.depths_mm.size))
    if cal.camera_bit_depth is not None:
        attrs.create("camera_bit_depth", np.int64(cal.camera_bit_depth))
    if cal.gamma_precompensation is not None:
        attrs.create("gamma_precompensation", np.float64(cal.gamma_precompensation))

    ds = f.create_dataset("k_map", data=cal.k_map, dtype=np.float64, **_COMPRESSION)
    _set_str(ds.attrs, "units", "mm/rad")
    _set_str(ds.attrs, "description", "filtered linear phase-to-height map K, h = K .* dphi")
    ds = f.create_dataset(
        "reference_phase", data=cal.reference_phase, dtype=np.float64, **_COMPRESSION
    )
    _set_str(ds.attrs, "units", "rad")
    _set_str(ds.attrs, "description", "absolute phase of the reference plane, dphi = phi - this")
    ds = f.create_dataset("depths_mm", data=cal.depths_mm, dtype=np.float64)
    _set_str(ds.attrs, "units", "mm")
    if cal.coefficients is not None:
        ds = f.create_dataset(
            "coefficients", data=cal.coefficients, dtype=np.float64, **_COMPRESSION
        )
        _set_str_list(ds.attrs, "names", list(_COEFFICIENT_NAMES[cal.model]))
        _set_str(ds.attrs, "equation", _EQUATIONS[cal.model])
    for group_name in _RESIDUAL_GROUPS:
        group = f.create_group(group_name, track_order=True)
        _set_str(group.attrs, "units", "mm")
        for model, rms in getattr(cal, group_name).items():
            group.create_dataset(model, data=rms, dtype=np.float32, **_COMPRESSION)
    if cal.spec is not None:
        s = cal.spec
        group = f.create_group("spec", track_order=True)
        _set_str(group.attrs, "pattern", s.pattern)
        group.attrs.create("steps", np.int64(s.steps))
        group.attrs.create("pitch_px", np.float64(s.pitch_px))
        _set_str(group.attrs, "orientation", s.orientation)
        group.attrs.create("imin", np.float64(s.imin))
        group.attrs.create("migl", np.float64(s.migl))
    _write_tree(f.create_group("provenance", track_order=True), cal.provenance)


def save_calibration(path: str | Path, cal: Calibration, force: bool = False) -> Path:
    """Write a calibration as HDF5, atomically (:func:`hdrfringe.io.results.staged_output_file`).

    Parameters
    ----------
    path : str or Path
        Target file (conventionally ``*.h5``); parent folders are created.
    cal : Calibration
        The calibration to store.
    force : bool
        Replace an existing file; without it an existing file raises
        :class:`~hdrfringe.errors.OutputExistsError`.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    OutputExistsError
        ``path`` exists (and ``force`` is False) or is a folder.
    InputError
        ``cal`` is not a :class:`~hdrfringe.core.calibration.Calibration`, or fails
        :func:`~hdrfringe.core.calibration.check_calibration` (non-finite or insane values).

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from hdrfringe.core.calibration import Calibration
    >>> cal = Calibration("linear", np.full((2, 3), 0.5), None, np.zeros((2, 3)),
    ...                   np.array([2.0, 4.0]), border_px=0, provenance={"operator": "doctest"})
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = save_calibration(Path(tmp) / "cal.h5", cal)
    ...     back = load_calibration(path)
    >>> path.name, back.model, back.image_shape, back.provenance
    ('cal.h5', 'linear', (2, 3), {'operator': 'doctest'})
    >>> bool(np.array_equal(back.k_map, cal.k_map))
    True
    """
    from hdrfringe.io._hdf5 import save_hdf5

    if not isinstance(cal, Calibration):
        raise InputError(f"expected a Calibration, got {type(cal).__name__}")
    out = Path(path)
    check_calibration(cal, f"{out}: refusing to write the calibration")
    if out.is_dir():
        raise OutputExistsError(f"{out}: is a folder; give a file path for the calibration")
    if out.exists() and not force:
        raise OutputExistsError(
            f"{out}: calibration file exists; pass --force to replace it or choose another path"
        )
    # path may be the CheckedOutput of the command's start (check_output_file): then only the
    # file checked there is replaced; built in memory, signals held (io._hdf5, docs/safety.md)
    save_hdf5(path, lambda f: _write(f, cal), force=force)
    return out


# --------------------------------------------------------------------------------------------
# load
# --------------------------------------------------------------------------------------------
def _dataset(
    f: Any, name: str, where: str, ndim: int, shape: tuple[int | None, ...] | None = None
) -> np.ndarray:
    """Dataset ``name``, its declared shape checked before anything is read.

    ``shape`` gives the expected size of each axis (None: any, within
    :data:`~hdrfringe.limits.MAX_PROGRAM_FRAMES`): a small file declaring a huge array (HDF5
    stores an unwritten dataset in a few bytes) is refused instead of allocated.
    """
    import h5py

    item = f.get(name)
    if not isinstance(item, h5py.Dataset):
        raise CalibrationFileError(
            f"{where}: dataset /{name} is missing; the file is incomplete, recalibrate"
        )
    declared = tuple(item.shape) if item.shape is not None else ()
    if len(declared) != ndim or item.dtype.kind != "f":
        raise CalibrationFileError(
            f"{where}: dataset /{name} is not a {ndim}-D float array; the file is damaged, "
            "recalibrate"
        )
    want = shape if shape is not None else (None,) * ndim
    if any(w is not None and d != w for d, w in zip(declared, want, strict=True)) or any(
        w is None and d > MAX_PROGRAM_FRAMES for d, w in zip(declared, want, strict=True)
    ):
        expected = "x".join("N" if w is None else str(w) for w in want)
        raise CalibrationFileError(
            f"{where}: dataset /{name} declares shape {'x'.join(map(str, declared))}, "
            f"inconsistent with {expected} (image_height x image_width of the file, N <= "
            f"{MAX_PROGRAM_FRAMES}); the file is damaged, recalibrate"
        )
    arr = item[()]
    if not isinstance(arr, np.ndarray) or arr.ndim != ndim or arr.dtype.kind != "f":
        raise CalibrationFileError(
            f"{where}: dataset /{name} is not a {ndim}-D float array; the file is damaged, "
            "recalibrate"
        )
    return arr


def _image_size(attrs: Any, where: str) -> tuple[int, int]:
    """The file's ``image_height`` x ``image_width``, within the image pixel limit."""
    height = _get(attrs, "image_height", where)
    width = _get(attrs, "image_width", where)
    if (
        not isinstance(height, int)
        or not isinstance(width, int)
        or not (1 <= height and 1 <= width and height * width <= MAX_IMAGE_PIXELS)
    ):
        raise CalibrationFileError(
            f"{where}: image size {height!r} x {width!r} is not 1..{MAX_IMAGE_PIXELS} pixels "
            "(image_height, image_width); the file is damaged, recalibrate"
        )
    return height, width


def _read(f: Any, where: str) -> Calibration:
    import h5py

    attrs = f.attrs
    if "format" not in attrs or _decode(attrs["format"]) != FORMAT_NAME:
        raise CalibrationFileError(
            f"{where}: HDF5 file is not an hdrfringe calibration (no format = {FORMAT_NAME!r} "
            "attribute); give a calibration file written by hdrfringe"
        )
    if "kind" in attrs and _decode(attrs["kind"]) != "phase-to-height":
        raise CalibrationFileError(
            f"{where}: a {_decode(attrs['kind'])} calibration, not a phase-to-height one; "
            "read it with hdrfringe.io.stereo_file.load_stereo_calibration"
        )
    version = _get(attrs, "version", where)
    if version != FORMAT_VERSION:
        hint = "upgrade hdrfringe" if isinstance(version, int) and version > 1 else "recalibrate"
        raise CalibrationFileError(
            f"{where}: calibration file version {version} is not supported (this hdrfringe "
            f"reads version {FORMAT_VERSION}); {hint}"
        )
    model = _get(attrs, "model", where)
    if model not in MODELS:
        raise CalibrationFileError(
            f"{where}: unknown calibration model {model!r}; upgrade hdrfringe or recalibrate"
        )
    size = _image_size(attrs, where)
    k_map = _dataset(f, "k_map", where, 2, size)
    reference = _dataset(f, "reference_phase", where, 2, size)
    depths = _dataset(f, "depths_mm", where, 1)
    coefficients = (
        _dataset(f, "coefficients", where, 3, (N_COEFFICIENTS[model], *size))
        if model != "linear"
        else None
    )
    residuals: dict[str, dict[str, np.ndarray]] = {}
    for group_name in _RESIDUAL_GROUPS:
        group = f.get(group_name)
        maps: dict[str, np.ndarray] = {}
        if isinstance(group, h5py.Group):
            if len(group) > len(MODELS):
                raise CalibrationFileError(
                    f"{where}: group /{group_name} holds {len(group)} maps, more than one per "
                    "model; the file is damaged, recalibrate"
                )
            for name in group:
                maps[name] = _dataset(group, name, where, 2, size)
        residuals[group_name] = maps
    spec = None
    if "spec" in f:
        g = f["spec"].attrs
        spec = FringeSpec(
            pattern=_get(g, "pattern", where),
            steps=int(_get(g, "steps", where)),
            pitch_px=float(_get(g, "pitch_px", where)),
            orientation=_get(g, "orientation", where),
            imin=float(_get(g, "imin", where)),
            migl=float(_get(g, "migl", where)),
        )
    provenance = _read_tree(f["provenance"]) if "provenance" in f else {}
    return Calibration(
        model=model,
        k_map=k_map,
        coefficients=coefficients,
        reference_phase=reference,
        depths_mm=depths,
        residual_rms_mm=residuals["residual_rms_mm"],
        residual_rms_unfiltered_mm=residuals["residual_rms_unfiltered_mm"],
        filter_window_px=int(_get(attrs, "filter_window_px", where)),
        border_px=int(_get(attrs, "border_px", where)),
        spec=spec,
        gamma_precompensation=(
            float(_decode(attrs["gamma_precompensation"]))
            if "gamma_precompensation" in attrs
            else None
        ),
        camera_bit_depth=(
            int(_decode(attrs["camera_bit_depth"])) if "camera_bit_depth" in attrs else None
        ),
        image_shape=size,
        provenance=provenance,
    )


def _check_regular(src: Path) -> None:
    """Refuse a FIFO, device or socket before h5py opens it (a FIFO would block forever)."""
    try:
        check_regular_file(src, "calibration file", "check the path or calibrate first")
    except InputError as exc:
        raise CalibrationFileError(str(exc)) from None


def load_calibration(path: str | Path) -> Calibration:
    """Read a calibration written by :func:`save_calibration`.

    Parameters
    ----------
    path : str or Path
        The calibration file (HDF5, format ``hdrfringe-calibration``, version 1).

    Returns
    -------
    Calibration
        The calibration as saved, checked by the
        :class:`~hdrfringe.core.calibration.Calibration` constructor.

    Raises
    ------
    CalibrationFileError
        Missing file, not HDF5 or corrupt, an HDF5 file of something else, an unsupported
        version, missing/inconsistent contents, or values that fail
        :func:`~hdrfringe.core.calibration.check_calibration` (inf, all-NaN maps, a K or model that
        cannot give heights, a failed residual); the message says which and what to do.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from hdrfringe.core.calibration import Calibration
    >>> from hdrfringe.core.patterns import FringeSpec
    >>> coef = np.stack([np.full((2, 2), 2.0), np.full((2, 2), 0.01)])  # h ~ dphi / 2
    >>> cal = Calibration("rational", np.full((2, 2), 0.5), coef,
    ...                   np.zeros((2, 2)), np.array([2.0, 4.0, 6.0]), border_px=0,
    ...                   spec=FringeSpec("sinusoidal", 4, 12.0), camera_bit_depth=12)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     back = load_calibration(save_calibration(Path(tmp) / "cal.h5", cal))
    >>> back.model, back.coefficients.shape, back.spec.label(), back.camera_bit_depth
    ('rational', (2, 2, 2), 's4_p12_v_i40_g255', 12)
    """
    import h5py

    from hdrfringe.errors import environment_fault
    from hdrfringe.io._hdf5 import hdf5_memory_fault

    src = Path(path)
    if not src.exists():
        raise CalibrationFileError(
            f"{src}: calibration file not found; check the path or calibrate first"
        )
    if src.is_dir():
        raise CalibrationFileError(
            f"{src}: is a folder, not a calibration file; give the .h5 file written by calibrate"
        )
    _check_regular(src)
    try:
        f = h5py.File(src, "r")
    except OSError as exc:
        fault = environment_fault(exc, src, "read") or hdf5_memory_fault(exc, src)
        if fault is not None:  # permission, memory: the environment, not the file
            raise fault from None
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise CalibrationFileError(
            f"{src}: not an HDF5 file or corrupt ({reason}); give a calibration file written "
            "by hdrfringe or recalibrate"
        ) from exc
    try:
        with f:
            cal = _read(f, str(src))
    except CalibrationFileError:
        raise
    except (InputError, KeyError, ValueError, TypeError, OSError, UnicodeDecodeError) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        memory = hdf5_memory_fault(exc, src)
        if memory is not None:  # memory ran out: not damage (issue 31)
            raise memory from None
        raise CalibrationFileError(
            f"{src}: calibration file is damaged or inconsistent ({reason}); recalibrate"
        ) from exc
    try:
        check_calibration(cal, str(src))
    except InputError as exc:
        raise CalibrationFileError(str(exc)) from exc
    return cal


def coefficient_names(model: str) -> tuple[str, ...]:
    """Names of the coefficient maps stored for ``model`` (``("K",)`` for linear).

    The names are the attribute ``names`` of the file's ``/coefficients`` dataset, in order.

    Parameters
    ----------
    model : {"linear", "rational", "poly2", "poly3"}
        Calibration model (see :func:`hdrfringe.core.calibration.fit_model`).

    Returns
    -------
    tuple of str
        One name per coefficient map.

    Raises
    ------
    InputError
        Unknown model.

    Examples
    --------
    >>> coefficient_names("linear"), coefficient_names("rational"), coefficient_names("poly3")
    (('K',), ('a', 'b'), ('c1', 'c2', 'c3'))
    """
    if model == "linear":
        return ("K",)
    if model not in N_COEFFICIENTS:
        raise InputError(f"unknown calibration model {model!r}; use one of {', '.join(MODELS)}")
    return _COEFFICIENT_NAMES[model]
