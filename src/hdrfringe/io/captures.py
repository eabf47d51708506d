"""Capture folders (versions 1, 2 and 3 of the contract in docs/capture_format.md): read,
validate, write.

A capture folder is a ``manifest.json`` plus the single-channel PNG or TIFF images it names and,
in version 2, the side files holding the 2-D data of projector-image frames (MIGL maps, projector
images); in memory it is a :class:`hdrfringe.core.captures.Captures`. :func:`read_capture_folder`
validates everything (manifest fields, file paths, image sizes, bit depth, side files from their
headers before decoding, content digests, complete fringe sets, maps) *before* any processing
starts, so a bad folder fails with one clear :class:`~hdrfringe.errors.CaptureFormatError` and no
output is written; :func:`write_capture_folder` writes a :class:`~hdrfringe.core.captures.Captures`
as a folder, in the lowest version the captures fit in (version 1 whenever they can).
"""

from __future__ import annotations

import math
import posixpath
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core import strict_json
from hdrfringe.core._validation import full_scale, is_saturated
from hdrfringe.core.captures import (
    FORMAT_NAME,
    FORMAT_VERSION,
    FORMAT_VERSIONS,
    GAIN_DB_RANGE,
    Captures,
    ProjectorInfo,
)
from hdrfringe.core.frames import IMAGE_FRAMES, Frame
from hdrfringe.core.limits import (
    MAX_FOLDER_PIXELS,
    MAX_PROGRAM_FRAMES,
    MAX_PROJECTOR_PIXELS,
    MAX_STEPS,
)
from hdrfringe.core.patterns import ORIENTATIONS, PATTERNS
from hdrfringe.errors import CaptureFormatError
from hdrfringe.io._read_limits import check_memory, load_json_bounded, probe_image, reason_of
from hdrfringe.io.results import staged_output_dir, write_map_tiff

__all__ = [
    "DECODE_BYTES_PER_PIXEL",
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "FORMAT_VERSIONS",
    "IMAGE_SUFFIXES",
    "MAX_SIDE_FILE_PIXELS",
    "RGB_LUMA_WEIGHTS",
    "TIFF_CODECS",
    "check_folders_memory",
    "load_image",
    "load_side_file",
    "read_capture_folder",
    "read_manifest",
    "write_capture_folder",
    "write_side_files",
]

IMAGE_SUFFIXES = (".png", ".tif", ".tiff")
#: zlib level of the PNG files written (captures, side files, imported images). Lossless at
#: every level; camera images carry noise that zlib hardly compresses, so the fastest level
#: costs little space and writes several times faster than Pillow's default (the ratio for a
#: virtual capture: ``benchmarks/bench_png.py``).
PNG_COMPRESS_LEVEL = 1
MAP_SUFFIXES = (".tif", ".tiff")

#: Frame kinds of each capture-format version (version 2 adds the frames with 2-D data).
_KINDS = {
    1: ("fringe", "centerline", "uniform"),
    2: ("fringe", "centerline", "uniform", "pixelwise_fringe", "image"),
    3: ("fringe", "centerline", "uniform", "pixelwise_fringe", "image", "graycode"),
}
#: Fringe-frame fields of version 3: the shift angle and the phase offset, in degrees.
_PHASE_FIELDS = ("shift_deg", "phase_offset_deg")
#: The manifest field naming the side file, per kind with 2-D data.
_DATA_FIELDS = {"pixelwise_fringe": "migl_map", "image": "image"}
#: Most projector pixels a folder with side files may declare (a side file is checked against
#: the projector from its header, before decoding): 2^26, twice an 8K projector's 33 Mpx.
MAX_SIDE_FILE_PIXELS = MAX_PROJECTOR_PIXELS
#: Side-file containers read, by dtype (float32 only in TIFF).
_SIDE_DTYPES = {
    ".png": (np.dtype(np.uint8), np.dtype(np.uint16)),
    ".tif": (np.dtype(np.float32), np.dtype(np.uint8), np.dtype(np.uint16)),
    ".tiff": (np.dtype(np.float32), np.dtype(np.uint8), np.dtype(np.uint16)),
}

#: Pixel types of the maps listed in ``maps`` (what write_map_tiff writes, and float64).
_MAP_DTYPES = tuple(np.dtype(t) for t in (np.float32, np.float64, np.uint8, np.uint16))

#: Luma weights (ITU-R BT.601) used when a capture is an RGB image.
RGB_LUMA_WEIGHTS = (0.299, 0.587, 0.114)


#: The codec package tifffile needs for LZW, Deflate-predictor, JPEG and most other compressed
#: TIFFs (the lower bound tifffile's own ``codecs`` extra asks for); pyproject.toml requires it.
TIFF_CODECS = "imagecodecs>=2025.11.11"


def _fail(where: str, what: str, fix: str) -> CaptureFormatError:
    return CaptureFormatError(f"{where}: {what}; {fix}")


def _require(entry: dict[str, Any], key: str, where: str) -> Any:
    if key not in entry:
        raise _fail(where, f"missing field '{key}'", "add it as the capture format requires")
    return entry[key]


def _number(entry: dict[str, Any], key: str, where: str, *, positive: bool = False) -> float:
    v = _require(entry, key, where)
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise _fail(where, f"field '{key}' must be a finite number, got {v!r}", "fix the manifest")
    if positive and v <= 0:
        raise _fail(where, f"field '{key}' must be positive, got {v!r}", "fix the manifest")
    return float(v)


def _integer(entry: dict[str, Any], key: str, where: str, lo: int, hi: int) -> int:
    v = _require(entry, key, where)
    if isinstance(v, bool) or not isinstance(v, int) or not (lo <= v <= hi):
        raise _fail(
            where, f"field '{key}' must be an integer in {lo}..{hi}, got {v!r}", "fix the manifest"
        )
    return int(v)


def _choice(entry: dict[str, Any], key: str, where: str, allowed: Sequence[str]) -> str:
    v = _require(entry, key, where)
    if v not in allowed:
        raise _fail(
            where, f"unknown {key} {v!r}", f"use one of {', '.join(repr(a) for a in allowed)}"
        )
    return str(v)


def _safe_relpath(file: Any, where: str, key: str = "file") -> str:
    if not isinstance(file, str) or not file:
        raise _fail(where, f"field '{key}' must be a non-empty string, got {file!r}", "fix it")
    if any(ord(c) < 32 or ord(c) == 127 for c in file):  # NUL: the OS refuses the name
        raise _fail(
            where,
            f"field '{key}' {file!r} holds a control character (a NUL byte or a line break)",
            "name the image file with printable characters",
        )
    norm = posixpath.normpath(file.replace("\\", "/"))
    if posixpath.isabs(norm) or norm == ".." or norm.startswith("../") or ":" in norm.split("/")[0]:
        raise _fail(
            where,
            f"file path {file!r} leaves the capture folder",
            "image paths must be relative and stay inside the folder",
        )
    if not norm.lower().endswith(IMAGE_SUFFIXES):
        raise _fail(where, f"file {file!r} is not a PNG or TIFF image", "use .png, .tif or .tiff")
    return norm


def _confined(folder: Path, rel: str, what: str) -> Path:
    """``folder / rel``, refused when it (through any symlink) resolves outside the folder."""
    path = folder / rel
    root = folder.resolve()
    target = path.resolve()
    if target != root and not target.is_relative_to(root):
        raise CaptureFormatError(
            f"{path}: {what} resolves to {target}, outside the capture folder (a symlink); "
            "copy the file into the folder"
        )
    return path


def _check_phase_fields(
    entry: dict[str, Any], kind: str, pattern: str, where: str, version: int
) -> None:
    """Version 3: a fringe frame's optional ``shift_deg`` and ``phase_offset_deg``."""
    given = [key for key in _PHASE_FIELDS if key in entry]
    if not given:
        return
    if version < 3:
        raise _fail(
            where,
            f"field '{given[0]}' needs capture format version 3",
            'set "version": 3 in the manifest (docs/capture_format.md)',
        )
    if kind != "fringe" or pattern != "sinusoidal":
        raise _fail(
            where,
            f"field '{given[0]}' applies to sinusoidal fringe frames only, not a {pattern} "
            f"{kind} frame",
            "leave it out (the contract's shifts apply)",
        )
    for key in given:
        _number(entry, key, where)


def _check_fringe_fields(entry: dict[str, Any], where: str, version: int = 1) -> None:
    pattern = _choice(entry, "pattern", where, PATTERNS)
    min_steps = 3 if pattern == "sinusoidal" else 2
    steps = _integer(entry, "steps", where, min_steps, MAX_STEPS)
    _integer(entry, "shift", where, 0, steps - 1)
    _number(entry, "pitch", where, positive=True)
    _choice(entry, "orientation", where, ORIENTATIONS)
    levels = [key for key in ("imin", "migl") if key in entry]
    if version >= 3 and entry.get("kind") == "fringe" and len(levels) < 2:
        # version 3: a fringe frame may leave out both (decoding does not use them)
        if levels:
            other = "migl" if levels[0] == "imin" else "imin"
            raise _fail(
                where,
                f"gives '{levels[0]}' without '{other}'",
                "give both gray levels or neither (then imin 0 and migl 2^Bp - 1 are assumed)",
            )
        imin, migl = 0.0, 1.0
    else:
        imin = _number(entry, "imin", where)
        migl = _number(entry, "migl", where)
    if not 0 <= imin < migl:
        raise _fail(
            where,
            f"need 0 <= imin < migl, got imin={imin:g}, migl={migl:g}",
            "fix the manifest",
        )
    if "exposure_ms" in entry:
        _number(entry, "exposure_ms", where, positive=True)
    if "gamma_precompensation" in entry:
        _number(entry, "gamma_precompensation", where, positive=True)
    if "set" in entry and not isinstance(entry["set"], str):
        raise _fail(where, f"field 'set' must be a string label, got {entry['set']!r}", "fix it")
    _check_phase_fields(entry, str(entry.get("kind")), pattern, where, version)


def _check_side_file_fields(entry: dict[str, Any], kind: str, where: str) -> str:
    """Version 2: the side-file path (normalised) and the optional content digest."""
    key = _DATA_FIELDS[kind]
    rel = _safe_relpath(_require(entry, key, where), where, key)
    digest = entry.get("content_sha256")
    if digest is not None and not (
        isinstance(digest, str)
        and len(digest) == 64
        and all(c in "0123456789abcdef" for c in digest)
    ):
        raise _fail(
            where,
            f"field 'content_sha256' must be 64 lowercase hex digits, got {digest!r}",
            "rewrite it from the side file or leave it out",
        )
    if kind == "image":
        name = _require(entry, "name", where)
        if not isinstance(name, str) or not name.strip():
            raise _fail(where, f"field 'name' must be a non-empty string, got {name!r}", "fix it")
    return rel


def _check_graycode_fields(entry: dict[str, Any], where: str, version: int) -> None:
    """A ``graycode`` frame (version 3): orientation, bit, bits, stripe; optional inverse,
    code, migl, convention, exposure_ms."""
    from hdrfringe.core.graycode import CODES as GRAYCODE_CODES
    from hdrfringe.core.graycode import MAX_BITS as GRAYCODE_MAX_BITS

    if version < 3:
        raise _fail(
            where,
            "kind 'graycode' needs capture format version 3",
            'set "version": 3 in the manifest (docs/capture_format.md)',
        )
    _choice(entry, "orientation", where, ORIENTATIONS)
    bits = _integer(entry, "bits", where, 1, GRAYCODE_MAX_BITS)
    _integer(entry, "bit", where, 0, bits - 1)
    _number(entry, "stripe", where, positive=True)
    if "inverse" in entry and not isinstance(entry["inverse"], bool):
        raise _fail(
            where, f"field 'inverse' must be true or false, got {entry['inverse']!r}", "fix it"
        )
    if "code" in entry:
        _choice(entry, "code", where, GRAYCODE_CODES)
    if "migl" in entry:
        _number(entry, "migl", where, positive=True)
    if "convention" in entry and not isinstance(entry["convention"], str):
        raise _fail(
            where,
            f"field 'convention' must be a string label, got {entry['convention']!r}",
            "fix it",
        )


def _validate_frame(entry: Any, index: int, version: int) -> dict[str, Any]:
    where = f"manifest frame {index}"
    if not isinstance(entry, dict):
        raise _fail(
            where, "is not a JSON object", "each frame must be an object with 'file' and 'kind'"
        )
    file = _safe_relpath(_require(entry, "file", where), where)
    where = f"manifest frame {index} ({file})"
    kind = _require(entry, "kind", where)
    if version == 1 and isinstance(kind, str) and kind in _DATA_FIELDS:
        raise _fail(
            where,
            f"kind {kind!r} needs capture format version 2",
            'set "version": 2 in the manifest (docs/capture_format.md)',
        )
    if kind == "graycode":  # version 3 (docs/capture_format.md, "Gray-code frames")
        _check_graycode_fields(entry, where, version)
    kind = _choice(entry, "kind", where, _KINDS[version])
    out = dict(entry)
    out["file"] = file
    if kind in ("fringe", "pixelwise_fringe"):
        _check_fringe_fields(entry, where, version)
    elif kind == "centerline":
        _choice(entry, "orientation", where, ORIENTATIONS)
        _number(entry, "position", where)
        _number(entry, "migl", where, positive=True)
    elif kind == "uniform":
        _number(entry, "level", where)
    if kind in _DATA_FIELDS:
        out[_DATA_FIELDS[kind]] = _check_side_file_fields(entry, kind, where)
    if "exposure_ms" in entry:  # any frame may give its exposure time
        _number(entry, "exposure_ms", where, positive=True)
    if version >= 2 and "gain_db" in entry:  # version 1 gives gain_db no meaning
        gain = _number(entry, "gain_db", where)
        lo, hi = GAIN_DB_RANGE
        if not lo <= gain <= hi:
            raise _fail(
                where,
                f"field 'gain_db' must be in {lo:g}..{hi:g} dB, got {gain:g}",
                "fix the manifest",
            )
    return out


def read_manifest(folder: str | Path) -> dict[str, Any]:
    """Parse and validate a capture folder's ``manifest.json`` (fields only, no images).

    Parameters
    ----------
    folder : str or Path
        The capture folder.

    Returns
    -------
    dict
        The manifest, with every frame's ``file`` normalised; top-level fields hdrfringe does
        not read (e.g. ``simulator``) are kept.

    Raises
    ------
    CaptureFormatError
        A missing or unparsable manifest or any field breaking the contract. Every field
        problem is collected (camera, projector, scene, each frame) and reported in one error:
        its :attr:`~hdrfringe.errors.CaptureFormatError.problems` lists them all, its message
        shows the first in full and the rest in short. A manifest that cannot be read at all
        (not JSON, wrong ``format`` or ``version``, no ``frames`` list) stops at that problem.

    Examples
    --------
    >>> import json, tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> frames = [{"file": "./g.png", "kind": "uniform", "level": 128}]
    >>> manifest = {"format": "hdrfringe-captures", "version": 1,
    ...             "camera": {"bit_depth": 8}, "frames": frames}
    >>> _ = (folder / "manifest.json").write_text(json.dumps(manifest))
    >>> read_manifest(folder)["frames"][0]["file"]
    'g.png'
    """
    manifest, problems = _check_manifest(Path(folder))
    if problems:
        raise CaptureFormatError.from_problems(problems)
    return manifest


def _collect(problems: list[str], check: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
    """Run one check; on a CaptureFormatError record its problems and return None."""
    try:
        return check(*args, **kwargs)
    except CaptureFormatError as exc:
        problems.extend(exc.problems)
        return None


def _check_manifest(folder: Path) -> tuple[dict[str, Any], list[str]]:
    """The manifest with its frames validated (None where a frame failed) and every problem.

    Problems that make the rest unreadable (no folder or manifest, not a JSON object, wrong
    ``format`` or ``version``, no ``frames`` list, too many frames) are raised at once.
    """
    if not folder.is_dir():
        raise CaptureFormatError(
            f"{folder}: not a folder; give a capture folder holding manifest.json and its images"
        )
    mpath = folder / "manifest.json"
    if not mpath.is_file():
        raise CaptureFormatError(
            f"{folder}: no manifest.json; a capture folder needs one listing its frames "
            "(see docs/capture_format.md)"
        )
    manifest = load_json_bounded(_confined(folder, "manifest.json", "manifest"))
    where = str(mpath)
    if not isinstance(manifest, dict):
        raise _fail(where, "top level is not a JSON object", "see docs/capture_format.md")
    if manifest.get("format") != FORMAT_NAME:
        raise _fail(
            where,
            f"format is {manifest.get('format')!r}, not {FORMAT_NAME!r}",
            f'set "format": "{FORMAT_NAME}"',
        )
    version = manifest.get("version")
    if isinstance(version, bool) or version not in FORMAT_VERSIONS:
        *head, last = (str(v) for v in FORMAT_VERSIONS)
        readable = f"{', '.join(head)} and {last}" if head else last
        raise _fail(
            where,
            f"unsupported version {version!r}",
            f"this hdrfringe reads versions {readable}: write one of them, or update hdrfringe",
        )
    version = int(version)
    frames = _require(manifest, "frames", where)
    if not isinstance(frames, list) or not frames:
        raise _fail(where, "'frames' must be a non-empty list", "list one entry per image")
    if len(frames) > MAX_PROGRAM_FRAMES:
        raise _fail(
            where,
            f"{len(frames)} frames, more than the limit of {MAX_PROGRAM_FRAMES}",
            "split the captures into several folders",
        )
    problems: list[str] = []
    camera = _collect(problems, _require, manifest, "camera", where)
    if camera is not None and not isinstance(camera, dict):
        problems.append(str(_fail(where, "'camera' is not an object", 'use {"bit_depth": B}')))
    elif camera is not None:
        _collect(problems, _integer, camera, "bit_depth", f"{where} camera", 1, 16)
        for key in ("focal_px", "standoff_mm"):  # the camera geometry, where given
            if key in camera:
                _collect(problems, _number, camera, key, f"{where} camera", positive=True)
        for key in ("read_noise_dn", "gain_dn_per_e"):  # the noise model, where given
            value = (
                _collect(problems, _number, camera, key, f"{where} camera")
                if key in camera
                else None
            )
            if value is not None and value < 0:
                problems.append(
                    str(
                        _fail(
                            f"{where} camera",
                            f"field '{key}' must be >= 0, got {camera[key]!r}",
                            "give the camera's noise in DN (gain in DN per electron)",
                        )
                    )
                )
    projector = manifest.get("projector")
    projector_ok = projector is None
    if projector is not None and not isinstance(projector, dict):
        problems.append(
            str(_fail(where, "'projector' is not an object", "see docs/capture_format.md"))
        )
    elif projector is not None:
        n_before = len(problems)
        pw = f"{where} projector"
        for key in ("width", "height"):
            if key in projector:
                _collect(problems, _integer, projector, key, pw, 1, 1 << 20)
        if "bit_depth" in projector:
            _collect(problems, _integer, projector, "bit_depth", pw, 1, 16)
        if "gamma_precompensation" in projector:
            _collect(problems, _number, projector, "gamma_precompensation", pw, positive=True)
        projector_ok = len(problems) == n_before
    scene = manifest.get("scene", {})
    if not isinstance(scene, dict):
        problems.append(
            str(_fail(where, "'scene' is not an object", "use an object or leave it out"))
        )
    elif "depth_mm" in scene:
        _collect(problems, _number, scene, "depth_mm", f"{where} scene")
    manifest = dict(manifest)
    manifest["frames"] = [
        _collect(problems, _validate_frame, e, i, version) for i, e in enumerate(frames)
    ]
    with_data = [
        i for i, e in enumerate(manifest["frames"]) if e is not None and e["kind"] in _DATA_FIELDS
    ]
    if with_data and projector_ok:
        first = f"{where} frame {with_data[0]}"
        if projector is None or "width" not in projector or "height" not in projector:
            problems.append(
                f"{first}: a {manifest['frames'][with_data[0]]['kind']} frame's side file "
                "covers the projector, but the manifest gives no projector width and height; "
                "add them to 'projector'"
            )
        else:
            pixels = int(projector["width"]) * int(projector["height"])
            if pixels > MAX_SIDE_FILE_PIXELS:
                problems.append(
                    f"{where} projector: {projector['width']}x{projector['height']} is {pixels} "
                    f"pixels, more than the {MAX_SIDE_FILE_PIXELS} a side file may hold; check "
                    "the projector size"
                )
    return manifest, problems


def load_image(path: str | Path, bit_depth: int) -> NDArray:
    """Read one capture image as a single-channel array and check it against the bit depth.

    RGB(A) images are converted to luma with the BT.601 weights (0.299, 0.587, 0.114) as
    float32; a pixel with any clipped colour channel is set to ``2^B - 1`` so that it still
    counts as saturated (:func:`hdrfringe.core._validation.is_saturated`). Grayscale images keep
    their integer dtype.

    Parameters
    ----------
    path : str or Path
        A PNG or TIFF file.
    bit_depth : int
        Camera bit depth B; values above ``2^B - 1`` are refused.

    Returns
    -------
    ndarray (H, W)

    Raises
    ------
    CaptureFormatError
        A missing, unreadable, multi-channel (other than RGB), non-integer or out-of-range image.

    Examples
    --------
    >>> import tempfile
    >>> import imageio.v3 as iio
    >>> path = Path(tempfile.mkdtemp()) / "img.png"
    >>> iio.imwrite(path, np.array([[0, 17], [254, 255]], dtype=np.uint8))
    >>> load_image(path, 8).tolist()
    [[0, 17], [254, 255]]
    >>> load_image(path, 7)  # 255 is above 2^7 - 1
    Traceback (most recent call last):
    ...
    hdrfringe.errors.CaptureFormatError: ...
    """
    path = Path(path)
    if not path.is_file():
        raise CaptureFormatError(
            f"{path}: image file named in the manifest does not exist; add it or fix the manifest"
        )
    header = probe_image(path)  # size from the header, before any pixel is decoded
    _check_image_layout(path, header.shape, header.dtype)
    _check_container_bits(path, header.dtype, bit_depth)
    try:
        if path.suffix.lower() in (".tif", ".tiff"):
            import tifffile

            img = tifffile.imread(path)
        else:
            import imageio.v3 as iio
            from PIL import Image

            with warnings.catch_warnings():  # within MAX_IMAGE_PIXELS, checked above
                warnings.simplefilter("ignore", Image.DecompressionBombWarning)
                img = iio.imread(path)
    except Exception as exc:  # any decoder failure: truncated, corrupt, not an image
        reason = reason_of(exc).strip("'\"")
        if "requires the 'imagecodecs' package" in reason:  # tifffile: a codec, not the file
            raise CaptureFormatError(
                f"{path}: cannot decode the image: {reason}, which is not installed (the file "
                f"is not damaged); install it with `pip install '{TIFF_CODECS}'`, a dependency "
                "of hdrfringe"
            ) from None
        raise CaptureFormatError(
            f"{path}: cannot read the image ({reason}); the file is corrupt or "
            "truncated: recapture or re-export it"
        ) from None
    img = np.asarray(img)
    _check_image_layout(path, img.shape, img.dtype)
    full = full_scale(bit_depth)
    if img.dtype.kind == "i" and img.size and img.min() < 0:
        raise CaptureFormatError(
            f"{path}: values go down to {int(img.min())}; camera counts are never negative: "
            "store them as unsigned integers"
        )
    if img.ndim == 3 and img.shape[-1] in (3, 4):
        rgb = img[..., :3]
        if rgb.max(initial=0) > full:
            raise CaptureFormatError(
                f"{path}: values reach {int(rgb.max())}, above 2^B - 1 = {full} for camera "
                f"bit depth {bit_depth}; fix camera.bit_depth in the manifest"
            )
        luma = rgb.astype(np.float32) @ np.asarray(RGB_LUMA_WEIGHTS, dtype=np.float32)
        clipped = is_saturated(rgb, bit_depth)
        # any channel clipped: three ORs, ten times faster than .any(axis=-1) over 3 channels
        luma[clipped[..., 0] | clipped[..., 1] | clipped[..., 2]] = full
        return luma
    if img.max(initial=0) > full:
        raise CaptureFormatError(
            f"{path}: values reach {int(img.max())}, above 2^B - 1 = {full} for camera bit "
            f"depth {bit_depth}; fix camera.bit_depth in the manifest"
        )
    return img


def _check_container_bits(path: Path, dtype: np.dtype, bit_depth: int) -> None:
    """Refuse integer images too narrow for the bit depth: a 12-bit manifest over 8-bit PNGs
    clips at 255, which is not 2^B - 1, so no clipped pixel would count as saturated."""
    bits = np.dtype(dtype).itemsize * 8
    if np.dtype(dtype).kind == "u" and bits < bit_depth:
        raise CaptureFormatError(
            f"{path}: {bits}-bit image, but camera.bit_depth is {bit_depth}: values clipped at "
            f"{(1 << bits) - 1} would not count as saturated (2^B - 1 = "
            f"{full_scale(bit_depth)}); fix camera.bit_depth in the manifest ({bits} for these "
            "images), or store the camera's full values"
        )


def _check_image_layout(path: Path, shape: tuple[int, ...], dtype: np.dtype) -> None:
    """A capture image is (H, W) or RGB(A) (H, W, 3|4) of 8- or 16-bit integers."""
    if not (len(shape) == 2 or (len(shape) == 3 and shape[-1] in (3, 4))):
        raise CaptureFormatError(
            f"{path}: image has shape {tuple(shape)}; captures must be single-channel "
            "(or RGB, converted to luma)"
        )
    if dtype.kind not in "ui" or dtype.itemsize > 2:
        raise CaptureFormatError(
            f"{path}: image dtype {dtype} is not an integer 8- or 16-bit container; "
            "store camera counts as 8- or 16-bit integers"
        )


def _read_map(path: Path, key: str, shape: tuple[int, ...]) -> NDArray:
    """One map listed in the manifest's ``maps``, its size and type checked from the header
    against the images before it is decoded."""
    header = probe_image(path, f"map {key!r}")
    _check_map(path, header.shape, header.dtype, shape)
    try:
        import tifffile

        data = np.asarray(tifffile.imread(path))
    except Exception as exc:  # any decoder failure: truncated, corrupt data
        reason = reason_of(exc)
        raise CaptureFormatError(
            f"{path}: cannot read map {key!r} ({reason}); regenerate it or remove the 'maps' entry"
        ) from None
    _check_map(path, data.shape, data.dtype, shape)
    return data


def _check_map(path: Path, got: tuple[int, ...], dtype: np.dtype, shape: tuple[int, ...]) -> None:
    if tuple(got) != tuple(shape):
        size = f"{got[1]}x{got[0]}" if len(got) == 2 else f"of shape {tuple(got)}"
        raise CaptureFormatError(
            f"{path}: map is {size} but the images are {shape[1]}x{shape[0]}; regenerate it"
        )
    if dtype not in _MAP_DTYPES:
        raise CaptureFormatError(
            f"{path}: map holds {dtype} values; store float32 (or 8- or 16-bit integers)"
        )


def _side_file_header(path: Path, suffix: str) -> tuple[tuple[int, ...], str]:
    """Shape and a description of a side file's pixel type, from its header only."""
    if suffix == ".png":
        from PIL import Image

        with Image.open(path) as im:
            width, height = im.size
            mode = im.mode
        if mode not in ("L", "I;16", "I;16B", "I;16L", "I"):
            raise CaptureFormatError(
                f"{path}: side file is a PNG of mode {mode}, not single-channel 8- or 16-bit "
                "gray; store the data as a gray PNG or a float32 TIFF"
            )
        return (height, width), mode
    import tifffile

    with tifffile.TiffFile(path) as tif:
        n_pages = len(tif.pages)
        page = tif.pages.first
        shape, dtype = tuple(page.shape), page.dtype
    if n_pages != 1:
        raise CaptureFormatError(
            f"{path}: side file holds {n_pages} TIFF pages; store one single-channel page"
        )
    if dtype not in _SIDE_DTYPES[suffix]:
        raise CaptureFormatError(
            f"{path}: side file holds {dtype} values; store float32 (or 8- or 16-bit integers)"
        )
    return shape, str(dtype)


def load_side_file(path: str | Path, projector: ProjectorInfo) -> NDArray[Any]:
    """Read one version-2 side file (a frame's 2-D data), checked against the projector.

    The size is checked from the file's header before any pixel is decoded: a side file holds
    exactly the projector's ``height x width`` values (at most :data:`MAX_SIDE_FILE_PIXELS`),
    single-channel, as a gray 8- or 16-bit PNG or a float32 (or 8-/16-bit integer) TIFF. After
    decoding, the values must be finite, non-negative and at most ``2^Bp - 1``.

    Parameters
    ----------
    path : str or Path
        The side file.
    projector : ProjectorInfo
        The folder's projector: its ``width``, ``height`` and ``bit_depth`` Bp.

    Returns
    -------
    ndarray, shape (projector height, projector width)
        In the file's dtype (uint8, uint16 or float32).

    Raises
    ------
    CaptureFormatError
        A missing, unreadable, wrongly sized, multi-channel or out-of-range side file.

    Notes
    -----
    The values are the projector's linear input gray levels (thesis Eq. 2.17 is applied when a
    frame is rendered); docs/capture_format.md, "Version 2".

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.io.results import write_map_tiff
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     write_map_tiff(Path(tmp) / "m.tiff", np.full((2, 3), 200.0))
    ...     data = load_side_file(Path(tmp) / "m.tiff", ProjectorInfo(3, 2, 8))
    >>> data.dtype, data.shape
    (dtype('float32'), (2, 3))
    """
    path = Path(path)
    if not path.is_file():
        raise CaptureFormatError(
            f"{path}: side file named in the manifest does not exist; add it or fix the manifest"
        )
    suffix = path.suffix.lower()
    expect = (int(projector.height), int(projector.width))
    try:
        shape, _ = _side_file_header(path, suffix)
    except CaptureFormatError:
        raise
    except Exception as exc:  # any header parser failure: truncated, corrupt, not an image
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise CaptureFormatError(
            f"{path}: cannot read the side file ({reason}); the file is corrupt or truncated: "
            "rewrite the folder"
        ) from None
    if shape != expect:
        got = f"{shape[1]}x{shape[0]}" if len(shape) == 2 else f"of shape {shape}"
        raise CaptureFormatError(
            f"{path}: side file is {got} but the projector is {expect[1]}x{expect[0]}; store "
            "one single-channel value per projector pixel (or fix the manifest's projector)"
        )
    try:
        if suffix == ".png":
            import imageio.v3 as iio

            data = np.asarray(iio.imread(path))
        else:
            import tifffile

            data = np.asarray(tifffile.imread(path))
    except Exception as exc:  # any decoder failure
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise CaptureFormatError(
            f"{path}: cannot decode the side file ({reason}); the file is corrupt or truncated: "
            "rewrite the folder"
        ) from None
    if data.shape != expect or data.dtype not in _SIDE_DTYPES[suffix]:
        raise CaptureFormatError(
            f"{path}: side file decodes to {data.dtype} of shape {data.shape}, not "
            f"{expect[1]}x{expect[0]} single-channel values; rewrite it"
        )
    full = full_scale(projector.bit_depth, "projector bit depth")
    if data.dtype.kind == "f" and not np.isfinite(data).all():
        raise CaptureFormatError(
            f"{path}: side file holds non-finite values; store finite gray levels"
        )
    lo, hi = (data.min(), data.max()) if data.size else (0, 0)
    if lo < 0 or hi > full:
        raise CaptureFormatError(
            f"{path}: side file values span {lo:g}..{hi:g}, outside the projector's "
            f"0..{full} at {projector.bit_depth} bits; fix the data or the projector bit depth"
        )
    return data


class _SideFileLoader:
    """``load_array`` for :meth:`Captures.from_manifest`: reads each side file of a folder once."""

    def __init__(self, folder: Path, projector: ProjectorInfo) -> None:
        self.folder = folder
        self.projector = projector
        self._cache: dict[str, NDArray[Any]] = {}

    def __call__(self, rel: str) -> NDArray[Any]:
        rel = _safe_relpath(rel, f"{self.folder / 'manifest.json'} side file", "side file")
        if rel not in self._cache:
            path = _confined(self.folder, rel, "side file")
            self._cache[rel] = load_side_file(path, self.projector)
        return self._cache[rel]


#: Bytes that decoding a folder (``phase``, ``measure``) needs per pixel of its images, at
#: least: one 4-step set of 8-bit images took 19.8 B per image pixel with ``phase
#: --no-previews`` and 24.8 B with ``measure --no-previews`` (no calibration), beyond the
#: interpreter's own (peak RSS at 2000x2000 minus 1000x1000, divided by the 12 M image pixels
#: added; docs/capture_format.md, "Limits"). The lower of the two, rounded down, so that no folder
#: that fits is refused; 3-step sets and previews take more.
DECODE_BYTES_PER_PIXEL = 19


def _checked_images(folder: Path) -> tuple[dict[str, Any], list[Path], tuple[int, ...], int]:
    """A folder's manifest checked (every field problem reported together) and its images'
    headers: the manifest, the image paths, their one size (H, W) and the bytes of a pixel
    as decoded; the folder's pixels bounded by MAX_FOLDER_PIXELS. No pixel is decoded."""
    manifest, problems = _check_manifest(folder)
    # the folder's files, for every frame whose path is usable, reported with the field problems
    raw = [e.get("file") if isinstance(e, dict) else None for e in manifest["frames"]]
    files: list[str | None] = []
    for entry, file in zip(manifest["frames"], raw, strict=True):
        try:
            files.append(entry["file"] if entry is not None else _safe_relpath(file, ""))
        except CaptureFormatError:
            files.append(None)  # its problem is already listed
    seen: dict[str, int] = {}
    for i, file in enumerate(files):
        if file is None:
            continue
        if file in seen:
            problems.append(
                f"manifest frames {seen[file]} and {i} both name {file}; give each frame its "
                "own image"
            )
        else:
            seen[file] = i
    for i, entry in enumerate(manifest["frames"]):
        side = None if entry is None else entry.get(_DATA_FIELDS.get(entry["kind"], ""))
        if side is not None and side in seen:
            problems.append(
                f"manifest frame {i} names {side} as its side file, but it is the camera image of "
                f"frame {seen[side]}; keep projector data and camera images in separate files"
            )
    for file in dict.fromkeys(f for f in files if f is not None):
        image = _collect(problems, _confined, folder, file, "image")
        if image is not None and not image.is_file():
            problems.append(
                f"{image}: image file named in the manifest does not exist; add it or fix the "
                "manifest"
            )
    if problems:
        raise CaptureFormatError.from_problems(problems)
    entries: list[dict[str, Any]] = manifest["frames"]
    # every image's size from its header before any is decoded: one size, bounded in total
    paths = [_confined(folder, entry["file"], "image") for entry in entries]
    shape0: tuple[int, ...] = probe_image(paths[0]).shape[:2]
    pixel_bytes = 1
    for path in paths:
        header = probe_image(path)
        _check_image_layout(path, header.shape, header.dtype)
        _check_size(path, header.shape[:2], shape0, entries[0]["file"])
        # as decoded: an RGB(A) image becomes float32 luma
        pixel_bytes = max(pixel_bytes, 4 if len(header.shape) == 3 else header.dtype.itemsize)
    total = len(paths) * math.prod(shape0)
    if total > MAX_FOLDER_PIXELS:
        raise CaptureFormatError(
            f"{folder}: {len(paths)} images of {shape0[1]}x{shape0[0]} are {total} pixels, more "
            f"than the limit of {MAX_FOLDER_PIXELS}; split the captures into several folders"
        )
    return manifest, paths, shape0, pixel_bytes


def check_folders_memory(
    paths: Sequence[str | Path],
    work_bytes_per_pixel: int = DECODE_BYTES_PER_PIXEL,
    kept_bytes_per_pixel: int = 8,
) -> None:
    """Refuse folders that are all held at once (``calibrate``'s plate positions,
    ``calibrate-stereo``'s poses) when they do not fit, before any image is decoded.

    :func:`read_capture_folder` checks one folder; a command that reads every folder first
    and then decodes them one by one needs all their images, the decoding work of the
    largest and what it keeps of each decoded folder (a phase map) at once.

    Parameters
    ----------
    paths : sequence of str or Path
        The capture folders.
    work_bytes_per_pixel : int
        Decoding work per image pixel of one folder (:data:`DECODE_BYTES_PER_PIXEL`).
    kept_bytes_per_pixel : int
        Bytes kept per camera pixel of each decoded folder (8: one float64 map).

    Raises
    ------
    CaptureFormatError
        A folder's manifest or image headers are invalid (as :func:`read_capture_folder`
        says), or the total needs more memory than is available, saying how much.

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.core.patterns import FringeSpec
    >>> caps = Captures(FringeSpec(steps=3).frames(), np.zeros((3, 4, 5), np.uint8), 8)
    >>> root = Path(tempfile.mkdtemp())
    >>> folders = [write_capture_folder(root / f"p{i}", caps) for i in range(3)]
    >>> check_folders_memory(folders)  # 3 x 60 image bytes + 60 x 19 + 3 x 20 x 8: fits
    """
    images = work = kept = 0
    count = 0
    shape: tuple[int, ...] = (0, 0)
    for path in paths:
        _, files, shape, pixel_bytes = _checked_images(Path(path))
        pixels = len(files) * math.prod(shape)
        images += pixels * pixel_bytes
        work = max(work, pixels * work_bytes_per_pixel)
        kept += math.prod(shape) * kept_bytes_per_pixel
        count += 1
    if count > 1:
        where = f"{paths[0]} and {count - 1} more folders"
        check_memory(
            images + work + kept,
            where,
            f"{count} folders of {shape[1]}x{shape[0]} images held together",
            "use fewer folders, crop the images, or free memory",
        )


def read_capture_folder(path: str | Path, *, work_bytes_per_pixel: int = 0) -> Captures:
    """Read and fully validate a capture folder.

    Parameters
    ----------
    path : str or Path
        Folder holding ``manifest.json`` and its images.
    work_bytes_per_pixel : int
        Bytes the caller's work needs per pixel of the images, at least (the decoders:
        :data:`DECODE_BYTES_PER_PIXEL`); with the images' own, checked against the available
        memory from the image headers, before any pixel is decoded (default 0: the images' own).

    Returns
    -------
    Captures
        Every image loaded, shape (n_frames, H, W), and every map listed in the manifest's
        ``maps`` loaded as an array; ``name`` is the folder path.

    Raises
    ------
    CaptureFormatError
        Any breach of the contract, with what, where and how to fix it. The manifest's field
        problems, file names given twice and missing image files are collected and reported
        together (the error's ``problems`` lists them all); then the images are checked and
        decoded (the first bad image stops the read), then the fringe sets (every incomplete
        or inconsistent set is reported together).

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.core.patterns import FringeSpec
    >>> caps = Captures(FringeSpec(steps=3).frames(), np.zeros((3, 4, 5), np.uint8), 8)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     back = read_capture_folder(write_capture_folder(Path(tmp) / "caps", caps))
    >>> back.sets[0].label, np.array_equal(back.images, caps.images), back.name.endswith("caps")
    ('s3_p6_v_i40_g255', True, True)
    """
    folder = Path(path)
    manifest, paths, shape0, pixel_bytes = _checked_images(folder)
    bit_depth = int(manifest["camera"]["bit_depth"])
    entries: list[dict[str, Any]] = manifest["frames"]
    check_memory(  # the images as decoded plus the caller's work, before decoding any
        len(paths) * math.prod(shape0) * (pixel_bytes + work_bytes_per_pixel),
        str(folder),
        f"{len(paths)} images of {shape0[1]}x{shape0[0]}",
        "split the captures into several folders, crop the images, or free memory",
    )
    images: list[NDArray] = []
    for path in paths:
        img = load_image(path, bit_depth)
        _check_size(path, img.shape[:2], shape0, entries[0]["file"])
        images.append(img)
    kinds = {im.dtype for im in images}
    dtype = np.result_type(*kinds) if len(kinds) > 1 else images[0].dtype
    stack = np.stack([im.astype(dtype, copy=False) for im in images])
    listed = manifest.get("maps", {})
    if not isinstance(listed, dict):
        raise _fail(str(folder / "manifest.json"), "'maps' is not an object", "use {name: file}")
    maps: dict[str, NDArray] = {}
    for key, file in listed.items():
        rel = (
            _safe_relpath(file, f"manifest map {key!r}")
            if str(file).lower().endswith(MAP_SUFFIXES)
            else None
        )
        if rel is None or not (folder / rel).is_file():
            raise CaptureFormatError(
                f"{folder / 'manifest.json'}: map {key!r} names {file!r}, which is not a TIFF file "
                "in the folder; fix or remove the 'maps' entry"
            )
        maps[key] = _read_map(_confined(folder, rel, f"map {key!r}"), key, stack.shape[1:])
    projector = manifest.get("projector")
    loader = None
    if projector is not None:
        loader = _SideFileLoader(folder, ProjectorInfo.from_manifest(projector))
    return Captures.from_manifest(manifest, stack, maps, name=str(folder), load_array=loader)


def _check_size(path: Path, got: tuple[int, ...], shape0: tuple[int, ...], first: str) -> None:
    if tuple(got) != tuple(shape0):
        raise CaptureFormatError(
            f"{path}: image is {got[1]}x{got[0]} but {first} is {shape0[1]}x{shape0[0]}; all "
            "images of a folder must have one size"
        )


def _default_stems(frames: Sequence[Frame]) -> list[str]:
    stems = [f.default_name() for f in frames]
    if len(set(stems)) != len(stems):
        stems = [f"{i:04d}_{s}" for i, s in enumerate(stems)]
    return stems


def write_side_files(
    folder: str | Path,
    frames: Sequence[Frame],
    entries: Sequence[dict[str, Any]],
    projector: ProjectorInfo,
) -> list[str]:
    """Write the side files of the frames with 2-D data, each distinct file once.

    The path of each comes from the frame's manifest entry (its ``DATA_FIELD``, by default
    ``default_data_file()``, named by the content digest, so equal data is one file): a ``.tiff``
    holds float32 (:func:`hdrfringe.io.results.write_map_tiff`), a ``.png`` whole gray levels at
    the projector's bit depth (8-bit for Bp <= 8, else 16-bit).

    Parameters
    ----------
    folder : str or Path
        The (staging) folder the manifest will be written in; sub-folders are created.
    frames : sequence of Frame
        Every frame; line frames are skipped.
    entries : sequence of dict
        The frames' manifest entries, in the same order.
    projector : ProjectorInfo
        The projector the data must fit (size, bit depth).

    Returns
    -------
    list of str
        The side files written, relative to ``folder``, in first-use order.

    Raises
    ------
    CaptureFormatError
        Two different contents given one path, a path leaving the folder, data that does not
        fit the projector, or non-whole values for a PNG.

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.core.frames import ImageFrame
    >>> frames = [ImageFrame(np.eye(2) * 255, "a"), ImageFrame(np.eye(2) * 255, "b")]
    >>> entries = [f.manifest_entry(f"{i}.png") for i, f in enumerate(frames)]
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     written = write_side_files(tmp, frames, entries, ProjectorInfo(2, 2, 8))
    >>> len(written), written[0].startswith("projector/image_")
    (1, True)
    """
    import imageio.v3 as iio

    folder = Path(folder)
    plan: dict[str, Any] = {}
    for i, (frame, entry) in enumerate(zip(frames, entries, strict=True)):
        if not isinstance(frame, IMAGE_FRAMES):
            continue
        where = f"frame {i} ({entry.get('file')})"
        rel = _safe_relpath(entry[frame.DATA_FIELD], where, frame.DATA_FIELD)
        held = plan.setdefault(rel, frame)
        if held.content_sha256 != frame.content_sha256:
            raise CaptureFormatError(
                f"{where}: side file {rel} would hold two different contents; give the frames "
                "data files of their own (default_data_file names them by content)"
            )
    full = full_scale(projector.bit_depth, "projector bit depth")
    dtype = np.uint8 if projector.bit_depth <= 8 else np.uint16
    for rel, frame in plan.items():
        data = frame.data
        if data.shape != (projector.height, projector.width) or data.max() > full:
            raise CaptureFormatError(
                f"side file {rel}: {frame.kind} data of {data.shape[1]}x{data.shape[0]} up to "
                f"{data.max():g} does not fit the {projector.width}x{projector.height} projector "
                f"at {projector.bit_depth} bits; fix the frame or the projector"
            )
        target = folder / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        if rel.lower().endswith(MAP_SUFFIXES):
            write_map_tiff(target, data)
        else:
            if not np.array_equal(data, np.round(data)):
                raise CaptureFormatError(
                    f"side file {rel}: a PNG holds whole gray levels but the {frame.kind} data "
                    "has fractions; name a .tiff side file (float32)"
                )
            iio.imwrite(target, data.astype(dtype), compress_level=PNG_COMPRESS_LEVEL)
    return list(plan)


def write_capture_folder(
    path: str | Path,
    captures: Captures,
    *,
    names: Sequence[str] | None = None,
    extra: dict[str, Any] | None = None,
    force: bool = False,
) -> Path:
    """Write captures and their manifest as a capture folder.

    The folder is version 1 of the contract when the captures fit in it (no frame with 2-D
    data, no gain, no shift angles or phase offset), so such folders are the same, byte for
    byte, as before version 2 existed; otherwise the lowest version that describes them
    (:attr:`Captures.format_version`: 2 for 2-D data or gains, 3 for shift angles or a phase
    offset). Images go to PNG: 8-bit for
    ``camera_bit_depth <= 8``, 16-bit otherwise (float luma is rounded). Maps go beside them as
    float32 TIFF ``<key>.tiff``, listed in the manifest's ``maps``. The 2-D data of
    :class:`~hdrfringe.core.frames.PixelwiseFringeFrame` and
    :class:`~hdrfringe.core.frames.ImageFrame`
    goes to side files under ``projector/``, named by content so that equal data (the N frames
    of a pixelwise set) is stored once (:func:`write_side_files`). Everything is written to a
    staging directory and moved into place only when complete.

    Parameters
    ----------
    path : str or Path
        Target folder. If it exists and is not empty, ``force`` must be True.
    captures : Captures
        Frames, images, bit depth, projector, camera, scene, per-frame fields and maps.
    names : sequence of str, optional
        File stems; default from each frame's ``default_name()`` (prefixed with the frame
        index when two coincide).
    extra : dict, optional
        Additional top-level manifest fields (the contract allows additions), e.g.
        ``{"simulator": ...}``.
    force : bool
        Replace an existing non-empty folder.

    Returns
    -------
    Path
        The folder written.

    Raises
    ------
    CaptureFormatError
        Names that do not match the frames, or side-file data that cannot be stored.

    Notes
    -----
    docs/capture_format.md (versions 1, 2 and 3).

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.core.frames import UniformFrame
    >>> caps = Captures([UniformFrame(128)], np.full((1, 2, 3), 7, np.uint16), 12)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     out = write_capture_folder(Path(tmp) / "caps", caps, extra={"lab": "B2"})
    ...     m = strict_json.loads_strict((out / "manifest.json").read_text())
    >>> m["version"], m["camera"], m["lab"], m["frames"][0]["file"]
    (1, {'bit_depth': 12}, 'B2', 'gray_128.png')
    """
    import imageio.v3 as iio

    stems = list(names) if names is not None else _default_stems(captures.frames)
    if len(stems) != len(captures.frames):
        raise CaptureFormatError(
            f"write_capture_folder: {len(stems)} names for {len(captures.frames)} frames; "
            "give one file stem per frame"
        )
    manifest = captures.to_manifest([f"{s}.png" for s in stems], extra=extra)
    dtype = np.uint8 if captures.camera_bit_depth <= 8 else np.uint16
    with staged_output_dir(path, force=force) as tmp:
        for img, stem in zip(captures.images, stems, strict=True):
            iio.imwrite(
                tmp / f"{stem}.png", np.rint(img).astype(dtype), compress_level=PNG_COMPRESS_LEVEL
            )
        if captures.projector is not None:  # Captures requires it for frames with 2-D data
            write_side_files(tmp, captures.frames, manifest["frames"], captures.projector)
        for key, data in captures.maps.items():
            write_map_tiff(tmp / f"{key}.tiff", data)
        text = strict_json.dumps(manifest, nonfinite="error") + "\n"
        (tmp / "manifest.json").write_text(text, encoding="utf-8")
    return Path(path)
