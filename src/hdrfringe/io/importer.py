"""``hdrfringe import``: camera images plus a description of what was projected -> capture folder.

The images folder is searched recursively; each frame of the description (docs/import.md) must be
matched by exactly one file. Images the capture reader takes as they are (PNG or TIFF, 8- or
16-bit integers, gray or RGB) are copied byte for byte under their relative path; everything
else (``.npy``/``.npz`` stacks, float images, BMP/JPEG/PNM files, 32-bit integers) is converted,
without loss or refused, to PNG at the camera's bit depth (8-bit container for B <= 8, else
16-bit). Every image is checked (one size, values within 0..2^B - 1, the RGB rule of
:func:`hdrfringe.io.captures.load_image`) and the manifest is validated by the capture reader
before the folder is moved into place, so a bad import writes nothing.
"""

from __future__ import annotations

import dataclasses
import math
import os
import posixpath
import re
import shutil
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core import strict_json
from hdrfringe.core.captures import FORMAT_NAME, Captures, ProjectorInfo
from hdrfringe.core.limits import MAX_FOLDER_PIXELS, MAX_IMAGE_PIXELS, MAX_PROGRAM_FRAMES
from hdrfringe.errors import CaptureFormatError, InputError
from hdrfringe.io._read_limits import load_json_bounded, probe_image, reason_of
from hdrfringe.io.captures import PNG_COMPRESS_LEVEL, load_image, load_side_file, read_manifest
from hdrfringe.io.import_description import (
    REGEX_SECONDS,
    Description,
    FrameGroup,
    Template,
    read_description,
)
from hdrfringe.io.pattern_folder import PATTERN_FORMAT
from hdrfringe.io.results import check_output_against_inputs, staged_output_dir

__all__ = [
    "CONVERTED_SUFFIXES",
    "COPIED_SUFFIXES",
    "MAX_IMAGES_SCANNED",
    "ImportReport",
    "discover_images",
    "import_captures",
    "natural_key",
    "to_counts",
]

#: Suffixes copied as they are when they hold 8- or 16-bit integers.
COPIED_SUFFIXES = (".png", ".tif", ".tiff")
#: Suffixes decoded and written as PNG.
CONVERTED_SUFFIXES = (".bmp", ".jpg", ".jpeg", ".pgm", ".ppm", ".pnm")
_STACK_SUFFIXES = (".npy", ".npz")
#: Most files the recursive search of the images folder looks at.
MAX_IMAGES_SCANNED = 100_000
#: Float images: after scaling, a value may differ from the nearest integer by this many DN
#: plus float32 rounding of the value (2^-22 of it); anything more is a lossy conversion.
FLOAT_TOLERANCE_DN = 1e-3


@dataclass
class ImportReport:
    """What :func:`import_captures` did.

    Parameters
    ----------
    output : Path
        The capture folder written.
    manifest : dict
        Its manifest.
    copied, converted : int
        Images copied byte for byte, and images converted to PNG.
    ignored : list of str
        Files of the images folder that no frame uses (relative paths).

    Examples
    --------
    >>> ImportReport(Path("caps"), {"frames": []}, 0, 0).ignored
    []
    """

    output: Path
    manifest: dict[str, Any]
    copied: int
    converted: int
    ignored: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class _Source:
    """Where one frame's image comes from: a file, or one frame of a stack."""

    rel: str  # relative to the images folder (POSIX)
    index: int | None = None  # stack frame
    key: str | None = None
    axes: str = "nyx"

    def label(self) -> str:
        return self.rel if self.index is None else f"{self.rel} frame {self.index}"


def natural_key(text: str) -> list[Any]:
    """Sort key comparing digit runs as numbers (``img2`` before ``img10``).

    Parameters
    ----------
    text : str

    Returns
    -------
    list

    Examples
    --------
    >>> sorted(["f10.png", "f2.png", "f1.png"], key=natural_key)
    ['f1.png', 'f2.png', 'f10.png']
    """
    return [(0, int(p), "") if p.isdigit() else (1, 0, p) for p in re.split(r"(\d+)", text) if p]


def discover_images(root: str | Path) -> list[str]:
    """Every file below ``root`` (recursively, not following links to folders), as sorted
    relative POSIX paths; hidden files and folders (``.name``) are skipped.

    Parameters
    ----------
    root : str or Path
        The images folder.

    Returns
    -------
    list of str

    Raises
    ------
    InputError
        ``root`` is not a folder, or holds more than :data:`MAX_IMAGES_SCANNED` files.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> (root / "v").mkdir(); _ = (root / "v" / "a.png").write_bytes(b"")
    >>> discover_images(root)
    ['v/a.png']
    """
    root = Path(root)
    if not root.is_dir():
        raise InputError(f"{root}: images folder does not exist; give the folder of camera images")
    found: list[str] = []
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames[:] = [d for d in dirnames if not d.startswith(".")]
        for name in filenames:
            if name.startswith("."):
                continue
            found.append(Path(dirpath, name).relative_to(root).as_posix())
            if len(found) > MAX_IMAGES_SCANNED:
                raise InputError(
                    f"{root}: more than {MAX_IMAGES_SCANNED} files below the images folder; "
                    "give the folder that holds only this capture"
                )
    return sorted(found, key=natural_key)


def to_counts(
    data: NDArray[Any], bit_depth: int, float_scale: float | None, where: str
) -> NDArray[np.integer]:
    """Camera counts of an image without loss: integers checked, floats scaled and checked.

    Integers must lie in ``0..2^B - 1``. Floats need ``float_scale`` (DN per unit: 1 when the
    floats hold counts, ``2^B - 1`` when they hold 0..1): after scaling every value must be
    finite, within ``0..2^B - 1`` and integral (within :data:`FLOAT_TOLERANCE_DN` plus float32
    rounding); anything else would change the data and is refused.

    Parameters
    ----------
    data : ndarray
        (H, W) or RGB(A) (H, W, 3|4).
    bit_depth : int
        Camera bit depth B.
    float_scale : float or None
        DN per unit for float data (None: float data is refused).
    where : str
        The source, for messages.

    Returns
    -------
    ndarray of uint8 (B <= 8) or uint16
        Same shape; alpha dropped.

    Raises
    ------
    CaptureFormatError
        Values out of range, non-integral after scaling, non-finite, or floats without a scale.

    Examples
    --------
    >>> to_counts(np.array([[0.0, 0.5], [1.0, 0.25]]), 8, 4.0, "ex").tolist()
    [[0, 2], [4, 1]]
    >>> to_counts(np.array([[0.3]]), 8, 1.0, "ex")
    Traceback (most recent call last):
    ...
    hdrfringe.errors.CaptureFormatError: ex: float values are not whole counts after scaling ...
    """
    a = np.asarray(data)
    if a.ndim == 3 and a.shape[-1] == 4:
        a = a[..., :3]
    if not (a.ndim == 2 or (a.ndim == 3 and a.shape[-1] == 3)):
        raise CaptureFormatError(
            f"{where}: image of shape {a.shape}; a frame is single-channel (H, W) or RGB (H, W, 3)"
        )
    full = (1 << bit_depth) - 1
    out_dtype = np.uint8 if bit_depth <= 8 else np.uint16
    if a.dtype.kind in "ui":
        lo, hi = (int(a.min()), int(a.max())) if a.size else (0, 0)
        if lo < 0 or hi > full:
            raise CaptureFormatError(
                f"{where}: values span {lo}..{hi}, outside 0..{full} for camera bit depth "
                f"{bit_depth}; fix camera.bit_depth"
            )
        return a.astype(out_dtype)
    if a.dtype.kind != "f":
        raise CaptureFormatError(
            f"{where}: pixel type {a.dtype} is not a number type; store counts as integers"
        )
    if float_scale is None:
        raise CaptureFormatError(
            f"{where}: float image; set camera.float_scale (DN per unit: 1 when the floats "
            f"hold counts, {full} when they hold 0..1) in the description (docs/import.md)"
        )
    dn = a.astype(np.float64) * float_scale
    if not np.isfinite(dn).all():
        raise CaptureFormatError(f"{where}: float image holds NaN or infinity; store counts")
    dlo, dhi = (float(dn.min()), float(dn.max())) if dn.size else (0.0, 0.0)
    if dlo < 0 or dhi > full + FLOAT_TOLERANCE_DN:
        raise CaptureFormatError(
            f"{where}: after scaling by {float_scale:g} the values span {dlo:g}..{dhi:g}, outside "
            f"0..{full} for camera bit depth {bit_depth}; fix float_scale or bit_depth"
        )
    rounded = np.rint(dn)
    err = np.abs(dn - rounded)
    bad = err > FLOAT_TOLERANCE_DN + np.abs(dn) * 2.0**-22
    if bad.any():
        i = int(np.flatnonzero(bad.ravel())[0])
        raise CaptureFormatError(
            f"{where}: float values are not whole counts after scaling by {float_scale:g} "
            f"({a.ravel()[i]:g} becomes {dn.ravel()[i]:g}); set camera.float_scale so that "
            "they are (docs/import.md), or store the counts as integers"
        )
    return np.clip(rounded, 0, full).astype(out_dtype)


def _inside(root: Path, rel: str, where: str) -> Path:
    path = root / rel
    real_root = root.resolve()
    target = path.resolve()
    if target != real_root and not target.is_relative_to(real_root):
        raise InputError(f"{where}: {rel!r} lies outside the folder {root}; give paths inside it")
    return path


def _example_name(template: Template, key: dict[str, Any]) -> str:
    """What a file of this frame would be called (for the 'not found' message)."""
    text = template.text
    if template.regex.pattern != text or not template.fields:  # a plain template
        back = {v: k for k, v in template.orientation_names.items()}
        for name in template.fields:
            value = key[name]
            if name == "orientation":
                shown = back.get(value, str(value))
            else:
                spec = template.specs.get(name, "")
                v = int(value) if float(value).is_integer() else value
                shown = format(v, spec) if spec else str(v)
            text = re.sub(r"\{" + name + r"(:[^}]*)?\}", shown.replace("\\", r"\\"), text)
    return text


def _match_group(group: FrameGroup, files: Sequence[str], root: Path) -> list[_Source]:
    """The source of each frame of ``group``, in frame order."""
    frames = group.frames
    if group.stack is not None:
        sel = group.stack_frames
        if sel is not None and len(sel) != len(frames):
            raise InputError(
                f"{group.where}: stack_frames lists {len(sel)} indices for {len(frames)} frames; "
                "give one stack index per frame"
            )
        _inside(root, group.stack, group.where)
        if not (root / group.stack).is_file():
            raise InputError(
                f"{group.where}: stack {group.stack!r} does not exist in {root}; fix the "
                "description"
            )
        if not group.stack.lower().endswith(_STACK_SUFFIXES):
            raise InputError(f"{group.where}: stack {group.stack!r} is not a .npy or .npz file")
        indices = sel if sel is not None else list(range(len(frames)))
        return [_Source(group.stack, i, group.key, group.axes) for i in indices]
    if isinstance(group.files, list):
        if len(group.files) != len(frames):
            raise InputError(
                f"{group.where}: 'files' lists {len(group.files)} paths for {len(frames)} frames "
                "(orientations x periods x steps); give one path per frame, in that order"
            )
        out = []
        for rel in group.files:
            rel = rel.replace("\\", "/")
            path = _inside(root, rel, group.where)
            if not path.is_file():
                raise InputError(
                    f"{group.where}: {rel!r} does not exist in {root}; fix the description"
                )
            out.append(_Source(Path(rel).as_posix()))
        return out
    template = group.files
    assert isinstance(template, Template)
    found: dict[tuple[Any, ...], list[str]] = {}
    deadline = time.monotonic() + REGEX_SECONDS  # one budget for all names (a regex's)
    for rel in files:
        values = template.parse(rel, timeout=deadline - time.monotonic())
        if values is not None:
            found.setdefault(tuple(values[f] for f in template.fields), []).append(rel)
    out = []
    for frame in frames:
        key = frame["_key"]
        wanted = tuple(key[f] for f in template.fields)
        hits = found.get(wanted, [])
        if not hits:
            raise InputError(
                f"{group.where}: no image for frame '{frame['_label']}': no file in {root} "
                f"matches {_example_name(template, key)!r}; fix the template or add the image"
            )
        if len(hits) > 1:
            raise InputError(
                f"{group.where}: {len(hits)} files match frame '{frame['_label']}' "
                f"({hits[0]!r} and {hits[1]!r}); make the template more specific"
            )
        out.append(_Source(hits[0]))
    return out


def _resolve_fringes(frames: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """The manifest entries of one group's fringe frames (docs/import.md, "Shifts").

    Per set (orientation and pitch): when the shift angles are the contract's equal shifts
    ``360*i/N`` in some order, each frame gets the index ``i`` of its angle and no ``shift_deg``
    (so a -120/0/+120 set is version 1 when there is no phase offset); otherwise the frames keep
    the description's order as shift indices and carry ``shift_deg`` (version 3). A nonzero
    phase offset (a sine profile adds -90) is written as ``phase_offset_deg`` (version 3).
    """
    sets: dict[tuple[Any, ...], list[int]] = {}
    for i, f in enumerate(frames):
        sets.setdefault((f["orientation"], f["pitch"]), []).append(i)
    out: list[dict[str, Any]] = [{} for _ in frames]
    for members in sets.values():
        steps = int(frames[members[0]]["steps"])
        angles = [float(frames[i]["_shift_deg"]) for i in members]
        idx = [a * steps / 360.0 for a in angles]
        standard = [round(v) % steps for v in idx]
        renumber = all(abs(v - round(v)) < 1e-9 for v in idx) and len(set(standard)) == steps
        for k, i in enumerate(members):
            f = frames[i]
            entry: dict[str, Any] = {}
            for key, value in f.items():
                if key.startswith("_"):
                    continue
                entry[key] = value
                if key == "steps":
                    entry["shift"] = standard[k] if renumber else k
            if not renumber:
                entry["shift_deg"] = _plain(angles[k])
            offset = float(f["_offset_deg"])
            if abs(math.remainder(offset, 360.0)) > 1e-9:
                entry["phase_offset_deg"] = _plain(offset)
            out[i] = entry
    return out


def _plain(value: float) -> float | int:
    """An integral float as int (``-120`` rather than ``-120.0`` in the manifest)."""
    return int(value) if float(value).is_integer() else float(value)


def _check_npz_member(path: Path, key: str) -> None:
    """Refuse an ``.npz`` array larger than a folder may hold, from its header, before the
    (possibly compressed) data is inflated."""
    import zipfile

    with zipfile.ZipFile(path) as zf, zf.open(f"{key}.npy") as f:
        major, _ = np.lib.format.read_magic(f)
        read = (
            np.lib.format.read_array_header_1_0
            if major == 1
            else np.lib.format.read_array_header_2_0
        )
        shape, _, dtype = read(f)
    pixels = math.prod(shape) // (3 if shape and shape[-1] == 3 else 1)
    if pixels > MAX_FOLDER_PIXELS or np.dtype(dtype).itemsize > 8:
        raise CaptureFormatError(
            f"{path}: array {key!r} of shape {shape} holds more than the {MAX_FOLDER_PIXELS} "
            "pixels a capture folder may hold; split it"
        )


def _read_stack(root: Path, src: _Source, where: str) -> NDArray[Any]:
    """The whole stack array, axes ordered (n, y, x)."""
    path = root / src.rel
    try:
        if src.rel.lower().endswith(".npz"):
            with np.load(path, allow_pickle=False) as z:
                names = list(z.files)
                key = src.key
                if key is None:
                    if len(names) != 1:
                        raise InputError(
                            f"{where}: {src.rel} holds arrays {names}; name one with 'key'"
                        )
                    key = names[0]
                if key not in names:
                    raise InputError(
                        f"{where}: {src.rel} has no array {key!r} (it holds {names}); fix 'key'"
                    )
                _check_npz_member(path, key)
                arr = z[key]
        else:
            if src.key is not None:
                raise InputError(f"{where}: 'key' names an array of a .npz; {src.rel} is .npy")
            arr = np.load(path, mmap_mode="r", allow_pickle=False)
    except InputError:
        raise
    except Exception as exc:
        raise CaptureFormatError(
            f"{path}: cannot read the stack ({reason_of(exc)}); the file is corrupt or not a "
            "numpy array"
        ) from None
    axes = src.axes
    if arr.ndim != len(axes):
        raise CaptureFormatError(
            f"{path}: the stack has {arr.ndim} axes {arr.shape} but 'axes' = {axes!r} names "
            f"{len(axes)}; give one letter per axis (a 4-D stack: import one part at a time)"
        )
    if len(axes) == 2:
        arr = arr[None]
        axes = "n" + axes
    arr = np.transpose(arr, [axes.index(c) for c in "nyx"])
    if arr.shape[1] * arr.shape[2] > MAX_IMAGE_PIXELS:
        raise CaptureFormatError(
            f"{path}: frames of {arr.shape[2]}x{arr.shape[1]} exceed {MAX_IMAGE_PIXELS} pixels"
        )
    return arr


class _Writer:
    """Loads, checks and stores each frame's image in the staging folder."""

    def __init__(self, root: Path, stage: Path, description: Description) -> None:
        self.root = root
        self.stage = stage
        self.bit_depth = description.camera_bit_depth
        self.float_scale = description.float_scale
        self.shape: tuple[int, int] | None = None
        self.first = ""
        self.pixels = 0
        self.copied = 0
        self.converted = 0
        self.used: set[str] = set()
        self._stacks: dict[tuple[str, str | None, str], NDArray[Any]] = {}
        self.frame_size = description.frame_size
        self.crop_offset = description.crop_offset

    def _paste(self, counts: NDArray[Any], label: str) -> NDArray[Any]:
        """A crop placed at ``crop_offset`` into a zero full frame (``frame_size``)."""
        if self.frame_size is None:
            return counts
        w, h = self.frame_size
        if counts.shape[:2] == (h, w) and self.crop_offset in (None, (0, 0)):
            return counts
        if self.crop_offset is None:
            raise InputError(
                f"{label}: image is {counts.shape[1]}x{counts.shape[0]}, not the camera frame "
                f"{w}x{h}; give --crop-offset X0,Y0 (where the crop starts in the frame)"
            )
        x0, y0 = self.crop_offset
        if x0 + counts.shape[1] > w or y0 + counts.shape[0] > h:
            raise InputError(
                f"{label}: a {counts.shape[1]}x{counts.shape[0]} crop at ({x0}, {y0}) does not "
                f"fit in the camera frame {w}x{h}; fix the crop offset or camera.frame_size"
            )
        out = np.zeros((h, w, *counts.shape[2:]), dtype=counts.dtype)
        out[y0 : y0 + counts.shape[0], x0 : x0 + counts.shape[1]] = counts
        return out

    def _size(self, shape: tuple[int, ...], label: str) -> None:
        hw = (int(shape[0]), int(shape[1]))
        if self.shape is None:
            self.shape, self.first = hw, label
        elif hw != self.shape:
            raise CaptureFormatError(
                f"{label}: image is {hw[1]}x{hw[0]} but {self.first} is "
                f"{self.shape[1]}x{self.shape[0]}; all frames must have one size"
            )
        self.pixels += hw[0] * hw[1]
        if self.pixels > MAX_FOLDER_PIXELS:
            raise CaptureFormatError(
                f"{label}: the frames exceed {MAX_FOLDER_PIXELS} pixels in total; import the "
                "captures in several folders"
            )

    def _claim(self, name: str, label: str) -> str:
        if name in self.used:
            raise CaptureFormatError(
                f"{label}: the output file {name} is already taken by another frame; rename "
                "one of the sources"
            )
        self.used.add(name)
        return name

    def _write_png(self, name: str, counts: NDArray[Any]) -> None:
        import imageio.v3 as iio

        target = self.stage / name
        target.parent.mkdir(parents=True, exist_ok=True)
        iio.imwrite(target, counts, compress_level=PNG_COMPRESS_LEVEL)
        self.converted += 1

    def store(self, src: _Source) -> str:
        """Check and store one frame's image; returns its file name in the capture folder."""
        label = str(self.root / src.label())
        if src.index is not None:
            skey = (src.rel, src.key, src.axes)
            if skey not in self._stacks:
                self._stacks[skey] = _read_stack(self.root, src, label)
            stack = self._stacks[skey]
            if not 0 <= src.index < stack.shape[0]:
                raise CaptureFormatError(
                    f"{label}: the stack holds {stack.shape[0]} frames; no frame {src.index} "
                    "(the group has more frames than the stack, or fix 'stack_frames')"
                )
            counts = to_counts(
                np.asarray(stack[src.index]), self.bit_depth, self.float_scale, label
            )
            counts = self._paste(counts, label)
            self._size(counts.shape, label)
            stem = src.rel.rsplit(".", 1)[0]
            if src.key is not None:
                stem += f"_{src.key}"
            name = self._claim(f"{stem}_{src.index:03d}.png", label)
            self._write_png(name, counts)
            return name
        path = self.root / src.rel
        suffix = path.suffix.lower()
        if suffix in _STACK_SUFFIXES:
            raise InputError(
                f"{label}: a numpy file named as an image; describe it with 'stack' "
                "(docs/import.md)"
            )
        if suffix in COPIED_SUFFIXES:
            header = probe_image(path)
            if header.dtype.kind in "ui" and header.dtype.itemsize <= 2:
                try:  # range, layout, the RGB rule: what the capture reader will check
                    load_image(path, self.bit_depth)
                except CaptureFormatError as exc:
                    raise CaptureFormatError(
                        str(exc).replace(
                            "camera.bit_depth in the manifest",
                            "camera.bit_depth in the description",
                        )
                    ) from None
                if self.frame_size is not None:
                    pasted = self._paste(np.asarray(self._decode(path, label)), label)
                    if pasted.shape != header.shape:  # a crop: written as the full frame
                        self._size(pasted.shape, label)
                        name = self._claim(src.rel.rsplit(".", 1)[0] + ".png", label)
                        self._write_png(name, pasted)
                        return name
                self._size(header.shape, label)
                name = self._claim(src.rel, label)
                target = self.stage / name
                target.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(path, target)
                self.copied += 1
                return name
            data = self._decode(path, label)
        elif suffix in CONVERTED_SUFFIXES:
            if (path.stat().st_size or 0) == 0:
                raise CaptureFormatError(f"{label}: empty file; recapture or remove it")
            data = self._decode(path, label)
        else:
            raise InputError(
                f"{label}: not an image hdrfringe reads (use PNG, TIFF, BMP, JPEG, PNM, or a "
                ".npy/.npz 'stack'); fix the template"
            )
        counts = self._paste(to_counts(data, self.bit_depth, self.float_scale, label), label)
        self._size(counts.shape, label)
        name = self._claim(src.rel.rsplit(".", 1)[0] + ".png", label)
        self._write_png(name, counts)
        return name

    @staticmethod
    def _decode(path: Path, label: str) -> NDArray[Any]:
        try:
            if path.suffix.lower() in (".tif", ".tiff"):
                import tifffile

                return np.asarray(tifffile.imread(path))
            import imageio.v3 as iio
            from PIL import Image

            with warnings.catch_warnings():
                warnings.simplefilter("error", Image.DecompressionBombWarning)
                return np.asarray(iio.imread(path))
        except Exception as exc:
            raise CaptureFormatError(
                f"{label}: cannot read the image ({reason_of(exc)}); the file is corrupt or "
                "truncated"
            ) from None


def _pattern_frames(
    manifest_path: Path, files: Sequence[str], root: Path
) -> tuple[list[dict[str, Any]], list[_Source], dict[str, Any], list[tuple[str, Path]]]:
    """A ``hdrfringe patterns`` manifest as the description: its frames in play order, matched
    to the camera images in natural order (one image per played frame)."""
    manifest = load_json_bounded(manifest_path)
    where = str(manifest_path)
    if not isinstance(manifest, dict) or manifest.get("format") != PATTERN_FORMAT:
        raise InputError(
            f"{where}: not a pattern manifest (format {PATTERN_FORMAT!r}); give a TOML "
            "description or the manifest.json written by 'hdrfringe patterns'"
        )
    frames = manifest.get("frames")
    if not isinstance(frames, list) or not frames or not all(isinstance(f, dict) for f in frames):
        raise InputError(f"{where}: 'frames' must be a non-empty list of objects")
    if len(frames) > MAX_PROGRAM_FRAMES:
        raise InputError(f"{where}: more than {MAX_PROGRAM_FRAMES} frames")
    images = [f for f in files if f.lower().endswith(COPIED_SUFFIXES + CONVERTED_SUFFIXES)]
    if len(images) != len(frames):
        raise InputError(
            f"{where}: {len(frames)} frames were played but {root} holds {len(images)} images; "
            "the k-th image in natural order is matched to the k-th frame: give exactly one "
            "image per frame"
        )
    side: list[tuple[str, Path]] = []
    for i, entry in enumerate(frames):
        for key in ("migl_map", "image"):
            if key in entry and isinstance(entry[key], str):
                rel = posixpath.normpath(entry[key].replace("\\", "/"))
                if posixpath.isabs(rel) or rel == ".." or rel.startswith("../"):
                    raise InputError(
                        f"{where}: frame {i} names side file {entry[key]!r} outside the pattern "
                        "folder; side files must stay inside it"
                    )
                path = _inside(manifest_path.parent, rel, f"{where} frame {i}")
                side.append((rel, path))
    entries = [{k: v for k, v in f.items() if k != "file"} for f in frames]
    return entries, [_Source(f) for f in images], manifest.get("projector", {}), side


def _check_manifest(folder: Path, n: int) -> None:
    """The capture reader's checks of the written manifest: its fields, then its sets (complete,
    no shift twice) on placeholder images (the real images were checked one by one)."""
    manifest = read_manifest(folder)
    projector = ProjectorInfo.from_manifest(manifest.get("projector", {}))
    Captures.from_manifest(
        manifest,
        np.zeros((n, 1, 1), np.uint8),
        load_array=lambda rel: load_side_file(folder / rel, projector),
    )


def import_captures(
    images: str | Path,
    description: str | Path,
    output: str | Path,
    *,
    bit_depth: int | None = None,
    crop_offset: tuple[int, int] | None = None,
    force: bool = False,
) -> ImportReport:
    """Build a capture folder from a folder of camera images and a description.

    Parameters
    ----------
    images : str or Path
        The camera images (searched recursively).
    description : str or Path
        A TOML import description (docs/import.md), or the ``manifest.json`` of a pattern
        folder written by ``hdrfringe patterns`` (then ``bit_depth`` is required and the
        k-th image in natural order is the k-th frame played).
    output : str or Path
        The capture folder to write.
    bit_depth : int, optional
        Camera bit depth, for a pattern manifest only (a TOML description gives it).
    crop_offset : tuple of int, optional
        ``(x0, y0)``: the images are crops of the camera frame ``camera.frame_size`` of the
        description starting at this pixel; each is written as the full frame, zero outside the
        crop, so that pixel coordinates are the frame's (overrides ``camera.crop_offset``).
    force : bool
        Replace an existing non-empty output folder.

    Returns
    -------
    ImportReport

    Raises
    ------
    InputError
        A bad description: unknown keys, missing or doubly matched files, inconsistent counts.
    CaptureFormatError
        An image that cannot be imported without loss, or that breaks the capture format.

    Notes
    -----
    The capture-folder contract is docs/capture_format.md; the phase convention of the frames
    (thesis Eq. 2.1-2.3) is kept by mapping the description's shifts to shift indices.

    Examples
    --------
    >>> import tempfile
    >>> import imageio.v3 as iio
    >>> tmp = Path(tempfile.mkdtemp())
    >>> (tmp / "cam").mkdir()
    >>> for k in range(3):
    ...     iio.imwrite(tmp / "cam" / f"img_{k}.png", np.full((4, 5), 10 * k, np.uint8))
    >>> _ = (tmp / "d.toml").write_text('[camera]\\nbit_depth = 8\\n'
    ...     '[[fringe]]\\nfiles = "img_{step}.png"\\nsteps = 3\\npitch = 16\\n')
    >>> rep = import_captures(tmp / "cam", tmp / "d.toml", tmp / "caps")
    >>> [f["shift"] for f in rep.manifest["frames"]], rep.copied
    ([0, 1, 2], 3)
    """
    root = Path(images)
    desc_path = Path(description)
    output = Path(output)
    check_output_against_inputs(output, [root, desc_path])
    files = discover_images(root)
    if desc_path.suffix.lower() == ".json":
        if bit_depth is None:
            raise InputError(
                f"{desc_path}: a pattern manifest holds no camera bit depth; give --bit-depth"
            )
        if isinstance(bit_depth, bool) or not 1 <= int(bit_depth) <= 16:
            raise InputError(f"--bit-depth must be 1..16, got {bit_depth}")
        entries, sources, projector, side = _pattern_frames(desc_path, files, root)
        desc = Description(int(bit_depth), None, dict(projector), [], str(desc_path))
    else:
        if bit_depth is not None:
            raise InputError(
                f"{desc_path}: --bit-depth is for pattern manifests; give the bit depth in the "
                "description's camera table"
            )
        desc = read_description(desc_path)
        if crop_offset is not None:
            if desc.frame_size is None:
                raise InputError(
                    f"{desc_path}: a crop offset needs the camera's full frame; add "
                    "frame_size = [WIDTH, HEIGHT] to the description's camera table"
                )
            x0, y0 = (int(v) for v in crop_offset)
            if x0 < 0 or y0 < 0:
                raise InputError(f"crop offset ({x0}, {y0}) must be >= 0")
            desc = dataclasses.replace(desc, crop_offset=(x0, y0))
        entries, sources, side = [], [], []
        for group in desc.groups:
            sources.extend(_match_group(group, files, root))
            if group.kind == "fringe":
                entries.extend(_resolve_fringes(group.frames))
            else:
                entries.extend(
                    {k: v for k, v in frame.items() if not k.startswith("_")}
                    for frame in group.frames
                )
        projector = desc.projector
    owner: dict[_Source, int] = {}
    for i, src in enumerate(sources):
        if src in owner:
            raise InputError(
                f"{desc_path}: {src.label()} is the image of two frames ({owner[src] + 1} and "
                f"{i + 1} in order); give each frame its own image"
            )
        owner[src] = i
    version = 1
    if any(e.get("kind") in ("pixelwise_fringe", "image") for e in entries):
        version = 2
    if any(
        "shift_deg" in e
        or "phase_offset_deg" in e
        or e.get("kind") == "graycode"
        or (e.get("kind") == "fringe" and "imin" not in e)
        for e in entries
    ):
        version = 3
    manifest: dict[str, Any] = {
        "format": FORMAT_NAME,
        "version": version,
        "camera": {"bit_depth": desc.camera_bit_depth},
    }
    if projector:
        manifest["projector"] = projector
    manifest["frames"] = []
    with staged_output_dir(output, force=force) as tmp:
        writer = _Writer(root, tmp, desc)
        for entry, src in zip(entries, sources, strict=True):
            manifest["frames"].append({"file": writer.store(src), **entry})
        for rel, path in side:
            target = tmp / rel
            if not target.exists():
                if not path.is_file():
                    raise InputError(f"{path}: side file named by the pattern manifest is missing")
                target.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(path, target)
        manifest["import"] = {"description": desc_path.name, "images": root.name}
        if desc.frame_size is not None:
            manifest["import"]["frame_size"] = list(desc.frame_size)
            manifest["import"]["crop_offset"] = list(desc.crop_offset or (0, 0))
        mpath = tmp / "manifest.json"
        mpath.write_text(strict_json.dumps(manifest, nonfinite="error") + "\n", encoding="utf-8")
        try:
            _check_manifest(tmp, len(entries))
        except CaptureFormatError as exc:
            raise CaptureFormatError(
                str(exc).replace(str(mpath), f"{desc_path} (as imported)").replace(str(tmp), "")
            ) from None
    used = {s.rel for s in sources} | {rel for rel, _ in side}
    ignored = [f for f in files if f not in used]
    return ImportReport(output, manifest, writer.copied, writer.converted, ignored)
