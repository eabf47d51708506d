"""Capture folders (version 1 of the contract in docs/capture_format.md): read, validate, write.

A capture folder is a ``manifest.json`` plus the single-channel PNG or TIFF images it names.
:func:`read_capture_folder` validates everything (manifest fields, file paths, image sizes, bit
depth, complete fringe sets) *before* any processing starts, so a bad folder fails with one
clear :class:`~hdrfringe.errors.CaptureFormatError` and no output is written.
"""

from __future__ import annotations

import json
import math
import posixpath
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.captures import ProjectorInfo
from hdrfringe.errors import CaptureFormatError, HdrFringeError
from hdrfringe.frames import CenterlineFrame, Frame, FringeFrame, UniformFrame, frame_from_manifest
from hdrfringe.io.results import read_map_tiff, staged_output_dir, write_map_tiff
from hdrfringe.patterns import ORIENTATIONS, PATTERNS, FringeSpec

FORMAT_NAME = "hdrfringe-captures"
FORMAT_VERSION = 1
IMAGE_SUFFIXES = (".png", ".tif", ".tiff")

#: Luma weights (ITU-R BT.601) used when a capture is an RGB image.
RGB_LUMA_WEIGHTS = (0.299, 0.587, 0.114)


@dataclass(frozen=True)
class FringeSet:
    """One complete phase-shifted set inside a capture folder.

    Attributes
    ----------
    label : str
        The manifest's ``set`` label, or a label built from the pattern specification.
    spec : FringeSpec
    frame_indices : tuple of int
        Indices into :attr:`CaptureFolder.frames`, ordered by shift (shift 0 first).
    exposure_ms : float or None
    gamma_precompensation : float or None
        Per-set pre-compensation exponent when the frames give one (an hdrfringe addition to
        the contract); None: the projector's ``gamma_precompensation``.
    """

    label: str
    spec: FringeSpec
    frame_indices: tuple[int, ...]
    exposure_ms: float | None = None
    gamma_precompensation: float | None = None


@dataclass
class CaptureFolder:
    """A validated capture folder with its images in memory."""

    path: Path
    manifest: dict[str, Any]
    camera_bit_depth: int
    projector: ProjectorInfo | None
    scene: dict[str, Any]
    frames: list[Frame]
    entries: list[dict[str, Any]]
    images: NDArray = field(repr=False)
    sets: list[FringeSet] = field(default_factory=list)
    maps: dict[str, Path] = field(default_factory=dict)
    memory_maps: dict[str, NDArray] = field(default_factory=dict, repr=False)

    @property
    def image_shape(self) -> tuple[int, int]:
        return (int(self.images.shape[1]), int(self.images.shape[2]))

    @classmethod
    def from_arrays(
        cls,
        frames: Sequence[Frame],
        images: NDArray,
        camera_bit_depth: int,
        *,
        projector: ProjectorInfo | None = None,
        scene: dict[str, Any] | None = None,
        camera_extra: dict[str, Any] | None = None,
        truth_height_mm: NDArray | None = None,
        label: str = "<memory>",
    ) -> CaptureFolder:
        """An in-memory capture folder (e.g. straight from a rig), validated like one on disk."""
        images = np.asarray(images)
        if images.ndim != 3 or images.shape[0] != len(frames):
            raise CaptureFormatError(
                f"{label}: {len(frames)} frames but images of shape {images.shape}; "
                "give one (H, W) image per frame"
            )
        full = 2**camera_bit_depth - 1
        if images.max(initial=0) > full:
            raise CaptureFormatError(
                f"{label}: values reach {images.max()}, above 2^B - 1 = {full}; fix the bit depth"
            )
        entries = [f.manifest_entry(f"{i:04d}.png") for i, f in enumerate(frames)]
        manifest: dict[str, Any] = {
            "format": FORMAT_NAME,
            "version": FORMAT_VERSION,
            "camera": {"bit_depth": int(camera_bit_depth), **(camera_extra or {})},
            "scene": dict(scene or {}),
            "frames": entries,
        }
        if projector is not None:
            manifest["projector"] = projector.to_manifest()
        folder = cls(
            path=Path(label),
            manifest=manifest,
            camera_bit_depth=int(camera_bit_depth),
            projector=projector,
            scene=dict(scene or {}),
            frames=list(frames),
            entries=entries,
            images=images,
            sets=_group_sets(entries, list(frames)),
        )
        if truth_height_mm is not None:
            folder.memory_maps["truth_height_mm"] = np.asarray(truth_height_mm)
        return folder

    def read_map(self, key: str) -> NDArray | None:
        """A float map listed in the manifest's ``maps`` (e.g. ``truth_height_mm``), or None."""
        if key in self.memory_maps:
            return self.memory_maps[key]
        if key not in self.maps:
            return None
        data = read_map_tiff(self.maps[key])
        if data.shape != self.image_shape:
            raise CaptureFormatError(
                f"{self.maps[key]}: map is {data.shape[1]}x{data.shape[0]} but the images are "
                f"{self.image_shape[1]}x{self.image_shape[0]}; regenerate it"
            )
        return data

    def set_images(self, fringe_set: FringeSet) -> NDArray:
        """Stack of the set's images, shape (N, H, W), shift 0 first."""
        return self.images[list(fringe_set.frame_indices)]

    def centerlines(self) -> list[tuple[CenterlineFrame, NDArray]]:
        """Every centerline frame with its image."""
        return [
            (f, self.images[i]) for i, f in enumerate(self.frames) if isinstance(f, CenterlineFrame)
        ]

    def uniforms(self) -> list[tuple[UniformFrame, NDArray]]:
        """Every uniform-gray frame with its image."""
        return [
            (f, self.images[i]) for i, f in enumerate(self.frames) if isinstance(f, UniformFrame)
        ]


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


def _safe_relpath(file: Any, where: str) -> str:
    if not isinstance(file, str) or not file:
        raise _fail(where, f"field 'file' must be a non-empty string, got {file!r}", "fix it")
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


def _validate_frame(entry: Any, index: int) -> dict[str, Any]:
    where = f"manifest frame {index}"
    if not isinstance(entry, dict):
        raise _fail(
            where, "is not a JSON object", "each frame must be an object with 'file' and 'kind'"
        )
    file = _safe_relpath(_require(entry, "file", where), where)
    where = f"manifest frame {index} ({file})"
    kind = _choice(entry, "kind", where, ("fringe", "centerline", "uniform"))
    out = dict(entry)
    out["file"] = file
    if kind == "fringe":
        pattern = _choice(entry, "pattern", where, PATTERNS)
        min_steps = 3 if pattern == "sinusoidal" else 2
        steps = _integer(entry, "steps", where, min_steps, 1000)
        _integer(entry, "shift", where, 0, steps - 1)
        _number(entry, "pitch", where, positive=True)
        _choice(entry, "orientation", where, ORIENTATIONS)
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
            raise _fail(
                where, f"field 'set' must be a string label, got {entry['set']!r}", "fix it"
            )
    elif kind == "centerline":
        _choice(entry, "orientation", where, ORIENTATIONS)
        _number(entry, "position", where)
        _number(entry, "migl", where, positive=True)
    else:
        _number(entry, "level", where)
    return out


def read_manifest(folder: Path) -> dict[str, Any]:
    """Parse and validate ``manifest.json`` (fields only; images are checked by the reader)."""
    folder = Path(folder)
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
    try:
        manifest = json.loads(mpath.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise CaptureFormatError(f"{mpath}: not valid JSON ({exc}); fix or regenerate it") from None
    where = str(mpath)
    if not isinstance(manifest, dict):
        raise _fail(where, "top level is not a JSON object", "see docs/capture_format.md")
    if manifest.get("format") != FORMAT_NAME:
        raise _fail(
            where,
            f"format is {manifest.get('format')!r}, not {FORMAT_NAME!r}",
            f'set "format": "{FORMAT_NAME}"',
        )
    if manifest.get("version") != FORMAT_VERSION:
        raise _fail(
            where,
            f"unsupported version {manifest.get('version')!r}",
            f"this hdrfringe reads version {FORMAT_VERSION}",
        )
    camera = _require(manifest, "camera", where)
    if not isinstance(camera, dict):
        raise _fail(where, "'camera' is not an object", 'use {"bit_depth": B}')
    _integer(camera, "bit_depth", f"{where} camera", 1, 16)
    projector = manifest.get("projector")
    if projector is not None:
        if not isinstance(projector, dict):
            raise _fail(where, "'projector' is not an object", "see docs/capture_format.md")
        pw = f"{where} projector"
        for key in ("width", "height"):
            if key in projector:
                _integer(projector, key, pw, 1, 1 << 20)
        if "bit_depth" in projector:
            _integer(projector, "bit_depth", pw, 1, 16)
        if "gamma_precompensation" in projector:
            _number(projector, "gamma_precompensation", pw, positive=True)
    scene = manifest.get("scene", {})
    if not isinstance(scene, dict):
        raise _fail(where, "'scene' is not an object", "use an object or leave it out")
    if "depth_mm" in scene:
        _number(scene, "depth_mm", f"{where} scene")
    frames = _require(manifest, "frames", where)
    if not isinstance(frames, list) or not frames:
        raise _fail(where, "'frames' must be a non-empty list", "list one entry per image")
    manifest = dict(manifest)
    manifest["frames"] = [_validate_frame(e, i) for i, e in enumerate(frames)]
    return manifest


def _group_sets(entries: list[dict[str, Any]], frames: list[Frame]) -> list[FringeSet]:
    groups: dict[tuple, list[int]] = {}
    for i, (entry, frame) in enumerate(zip(entries, frames, strict=True)):
        if not isinstance(frame, FringeFrame):
            continue
        key: tuple
        if "set" in entry:
            key = ("label", entry["set"])
        else:
            s = frame.spec
            key = ("spec", s, entry.get("exposure_ms"), entry.get("gamma_precompensation"))
        groups.setdefault(key, []).append(i)
    sets: list[FringeSet] = []
    for key, idx in groups.items():
        first = frames[idx[0]]
        assert isinstance(first, FringeFrame)
        spec = first.spec
        label = key[1] if key[0] == "label" else spec.label()
        exposure = entries[idx[0]].get("exposure_ms")
        if exposure is not None and key[0] == "spec":
            label = f"{label}_e{exposure:g}"
        gamma = entries[idx[0]].get("gamma_precompensation")
        if gamma is not None and key[0] == "spec":
            label = f"{label}_gp{gamma:g}"
        for i in idx:
            f = frames[i]
            assert isinstance(f, FringeFrame)
            if f.spec != spec:
                raise CaptureFormatError(
                    f"set {label!r}: frame {entries[i]['file']} has a different pattern "
                    "specification from the rest of its set; give each set one specification"
                )
        shifts = sorted(frames[i].shift for i in idx)  # type: ignore[union-attr]
        if shifts != list(range(spec.steps)):
            raise CaptureFormatError(
                f"set {label!r}: has shifts {shifts} but a {spec.steps}-step set needs each of "
                f"0..{spec.steps - 1} exactly once; add or remove frames"
            )
        ordered = tuple(sorted(idx, key=lambda i: frames[i].shift))  # type: ignore[union-attr]
        sets.append(
            FringeSet(label, spec, ordered, exposure, None if gamma is None else float(gamma))
        )
    return sets


def load_image(path: Path, bit_depth: int) -> NDArray:
    """Read one capture image as a single-channel array and check it against the bit depth.

    RGB(A) images are converted to luma with the BT.601 weights (0.299, 0.587, 0.114) as
    float32; a pixel with any clipped colour channel is set to ``2^B - 1`` so that it still
    counts as saturated. Grayscale images keep their integer dtype.
    """
    if not path.is_file():
        raise CaptureFormatError(
            f"{path}: image file named in the manifest does not exist; add it or fix the manifest"
        )
    try:
        if path.suffix.lower() in (".tif", ".tiff"):
            import tifffile

            img = tifffile.imread(path)
        else:
            import imageio.v3 as iio

            img = iio.imread(path)
    except Exception as exc:  # any decoder failure: truncated, corrupt, not an image
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise CaptureFormatError(
            f"{path}: cannot read the image ({reason}); the file is corrupt or truncated: "
            "recapture or re-export it"
        ) from None
    img = np.asarray(img)
    full = 2**bit_depth - 1
    if img.ndim == 3 and img.shape[-1] in (3, 4):
        rgb = img[..., :3]
        if rgb.max(initial=0) > full:
            raise CaptureFormatError(
                f"{path}: values reach {int(rgb.max())}, above 2^B - 1 = {full} for camera "
                f"bit depth {bit_depth}; fix camera.bit_depth in the manifest"
            )
        luma = rgb.astype(np.float32) @ np.asarray(RGB_LUMA_WEIGHTS, dtype=np.float32)
        luma[(rgb == full).any(axis=-1)] = full
        return luma
    if img.ndim != 2:
        raise CaptureFormatError(
            f"{path}: image has shape {img.shape}; captures must be single-channel "
            "(or RGB, converted to luma)"
        )
    if img.dtype.kind not in "ui":
        raise CaptureFormatError(
            f"{path}: image dtype {img.dtype} is not an integer 8- or 16-bit container; "
            "store camera counts as 8- or 16-bit integers"
        )
    if img.max(initial=0) > full:
        raise CaptureFormatError(
            f"{path}: values reach {int(img.max())}, above 2^B - 1 = {full} for camera bit "
            f"depth {bit_depth}; fix camera.bit_depth in the manifest"
        )
    return img


def read_capture_folder(path: str | Path) -> CaptureFolder:
    """Read and fully validate a capture folder.

    Parameters
    ----------
    path : str or Path
        Folder holding ``manifest.json`` and its images.

    Returns
    -------
    CaptureFolder
        With every image loaded, shape (n_frames, H, W).

    Raises
    ------
    CaptureFormatError
        Any breach of the contract, with what, where and how to fix it.
    """
    folder = Path(path)
    manifest = read_manifest(folder)
    bit_depth = int(manifest["camera"]["bit_depth"])
    entries: list[dict[str, Any]] = manifest["frames"]
    frames: list[Frame] = []
    for i, entry in enumerate(entries):
        try:
            frames.append(frame_from_manifest(entry))
        except HdrFringeError as exc:
            raise CaptureFormatError(f"manifest frame {i} ({entry['file']}): {exc}") from None
    seen: dict[str, int] = {}
    for i, entry in enumerate(entries):
        if entry["file"] in seen:
            raise CaptureFormatError(
                f"manifest frames {seen[entry['file']]} and {i} both name {entry['file']}; "
                "give each frame its own image"
            )
        seen[entry["file"]] = i
    sets = _group_sets(entries, frames)
    images: list[NDArray] = []
    shape0: tuple[int, ...] | None = None
    for entry in entries:
        img = load_image(folder / entry["file"], bit_depth)
        if shape0 is None:
            shape0 = img.shape
        elif img.shape != shape0:
            raise CaptureFormatError(
                f"{folder / entry['file']}: image is {img.shape[1]}x{img.shape[0]} but "
                f"{entries[0]['file']} is {shape0[1]}x{shape0[0]}; all images of a folder must "
                "have one size"
            )
        images.append(img)
    kinds = {im.dtype for im in images}
    dtype = np.result_type(*kinds) if len(kinds) > 1 else images[0].dtype
    stack = np.stack([im.astype(dtype, copy=False) for im in images])
    proj = manifest.get("projector")
    projector = None
    if proj is not None:
        projector = ProjectorInfo(
            width=int(proj.get("width", 1024)),
            height=int(proj.get("height", 768)),
            bit_depth=int(proj.get("bit_depth", 8)),
            gamma_precompensation=float(proj.get("gamma_precompensation", 1.0)),
        )
    maps: dict[str, Path] = {}
    listed = manifest.get("maps", {})
    if not isinstance(listed, dict):
        raise _fail(str(folder / "manifest.json"), "'maps' is not an object", "use {name: file}")
    for key, file in listed.items():
        rel = (
            _safe_relpath(file, f"manifest map {key!r}")
            if str(file).lower().endswith((".tif", ".tiff"))
            else None
        )
        if rel is None or not (folder / rel).is_file():
            raise CaptureFormatError(
                f"{folder / 'manifest.json'}: map {key!r} names {file!r}, which is not a TIFF file "
                "in the folder; fix or remove the 'maps' entry"
            )
        maps[key] = folder / rel
    return CaptureFolder(
        path=folder,
        maps=maps,
        manifest=manifest,
        camera_bit_depth=bit_depth,
        projector=projector,
        scene=dict(manifest.get("scene", {})),
        frames=frames,
        entries=entries,
        images=stack,
        sets=sets,
    )


def write_capture_folder(
    path: str | Path,
    frames: Sequence[Frame],
    images: NDArray,
    camera_bit_depth: int,
    *,
    projector: ProjectorInfo | dict[str, Any] | None = None,
    scene: dict[str, Any] | None = None,
    names: Sequence[str] | None = None,
    extra: dict[str, Any] | None = None,
    camera_extra: dict[str, Any] | None = None,
    maps: dict[str, NDArray] | None = None,
    force: bool = False,
) -> Path:
    """Write images and their manifest as a capture folder (contract version 1).

    Images go to PNG: 8-bit for ``camera_bit_depth <= 8``, 16-bit otherwise. The folder is
    written to a staging directory and moved into place only when complete.

    Parameters
    ----------
    path : str or Path
        Target folder. If it exists and is not empty, ``force`` must be True.
    frames : sequence of Frame
        What was projected for each image.
    images : ndarray, shape (n, H, W)
        Camera counts, at most ``2**camera_bit_depth - 1``.
    camera_bit_depth : int
    projector : ProjectorInfo or dict, optional
    scene : dict, optional
        E.g. ``{"name": "white_plate", "depth_mm": 12.0}``.
    names : sequence of str, optional
        File stems; default from each frame's :meth:`default_name`.
    extra : dict, optional
        Additional top-level manifest fields (the contract allows additions).
    camera_extra : dict, optional
        Additional ``camera`` fields, e.g. ``focal_px`` and ``standoff_mm``.
    maps : dict of str to ndarray, optional
        Extra float maps written beside the images as float32 TIFF ``<key>.tiff`` and listed in
        the manifest's ``maps`` field, e.g. ``{"truth_height_mm": h}``.
    force : bool
        Replace an existing non-empty folder.
    """
    import imageio.v3 as iio

    images = np.asarray(images)
    if images.ndim != 3 or images.shape[0] != len(frames):
        raise CaptureFormatError(
            f"write_capture_folder: {len(frames)} frames but images of shape {images.shape}; "
            "give one (H, W) image per frame"
        )
    full = 2**camera_bit_depth - 1
    if images.max(initial=0) > full or images.min(initial=0) < 0:
        raise CaptureFormatError(
            f"write_capture_folder: values outside 0..{full} for bit depth {camera_bit_depth}"
        )
    dtype = np.uint8 if camera_bit_depth <= 8 else np.uint16
    stems = list(names) if names is not None else [f.default_name() for f in frames]
    if len(set(stems)) != len(stems):
        stems = [f"{i:04d}_{s}" for i, s in enumerate(stems)]
    manifest: dict[str, Any] = {
        "format": FORMAT_NAME,
        "version": FORMAT_VERSION,
        "camera": {"bit_depth": int(camera_bit_depth), **(camera_extra or {})},
    }
    if projector is not None:
        manifest["projector"] = (
            projector.to_manifest() if isinstance(projector, ProjectorInfo) else dict(projector)
        )
    if scene:
        manifest["scene"] = dict(scene)
    if extra:
        manifest.update(extra)
    if maps:
        manifest["maps"] = {k: f"{k}.tiff" for k in maps}
    manifest["frames"] = [f.manifest_entry(f"{s}.png") for f, s in zip(frames, stems, strict=True)]
    with staged_output_dir(path, force=force) as tmp:
        for img, stem in zip(images, stems, strict=True):
            iio.imwrite(tmp / f"{stem}.png", np.rint(img).astype(dtype))
        for key, data in (maps or {}).items():
            write_map_tiff(tmp / f"{key}.tiff", data)
        (tmp / "manifest.json").write_text(json.dumps(manifest, indent=1) + "\n", encoding="utf-8")
    return Path(path)
