"""Hostile capture folders (issue 11): bounded up front, one-line errors, never a crash.

Each case here broke the reader before: a recursion, integer-parsing or float-overflow
traceback, a huge image decoded before its size was checked, a bad map or container accepted,
negative counts blamed on the folder instead of the file, a symlink leaving the folder followed.
"""

from __future__ import annotations

import json
import os
import struct
import subprocess
import sys
import textwrap
import zlib
from pathlib import Path

import numpy as np
import pytest
import tifffile

import hdrfringe.io.captures as io_captures
from hdrfringe.core.limits import (
    MAX_IMAGE_PIXELS,
    MAX_JSON_DEPTH,
    MAX_MANIFEST_BYTES,
    MAX_NUMBER_DIGITS,
    MAX_PROGRAM_FRAMES,
)
from hdrfringe.errors import CaptureFormatError, InputError
from hdrfringe.io.captures import read_capture_folder, read_manifest
from hdrfringe.io.results import read_map_tiff, write_map_tiff
from tests.conftest import run_cli


def _manifest(folder: Path) -> dict:
    return json.loads((folder / "manifest.json").read_text())


def _write_manifest(folder: Path, m: dict | str) -> None:
    text = m if isinstance(m, str) else json.dumps(m)
    (folder / "manifest.json").write_text(text)


def _one_line(exc: pytest.ExceptionInfo, *needles: str) -> str:
    msg = str(exc.value)
    assert "\n" not in msg and isinstance(exc.value, CaptureFormatError), msg
    for n in needles:
        assert n in msg, msg
    return msg


def _cli_refuses(folder: Path, *needles: str) -> None:
    out = folder.parent / "out"
    res = run_cli("phase", str(folder), "-o", str(out))
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert res.returncode == 2 and len(lines) == 1, res.stderr
    assert lines[0].startswith("error:") and "Traceback" not in res.stderr
    for n in needles:
        assert n in lines[0], lines[0]
    assert not out.exists() and not [p for p in folder.parent.iterdir() if p.name.startswith(".")]


def _bomb_tiff(path: Path, side: int = 60000, bits: int = 8, sample_format: int = 1) -> None:
    """A deflate TIFF declaring side x side pixels whose 60 strips decode to zeros: 3.6 MB on
    disk, 3.6 GB (8-bit) once decoded. Written tag by tag so that making it costs nothing."""
    rows = 1000
    strip = zlib.compress(bytes(rows * side * bits // 8), 9)
    n = -(-side // rows)
    tags = [  # (tag, type, count, value); type 3 SHORT, 4 LONG
        (256, 4, 1, side),
        (257, 4, 1, side),
        (258, 3, 1, bits),
        (259, 3, 1, 8),  # deflate
        (262, 3, 1, 1),  # black is zero
        (273, 4, n, None),  # strip offsets
        (277, 3, 1, 1),
        (278, 4, 1, rows),
        (279, 4, n, None),  # strip byte counts
        (339, 3, 1, sample_format),
    ]
    ifd_size = 2 + 12 * len(tags) + 4
    offsets_at = 8 + ifd_size
    counts_at = offsets_at + 4 * n
    data_at = counts_at + 4 * n
    ifd = struct.pack("<H", len(tags))
    for tag, typ, count, value in tags:
        if tag == 273:
            ifd += struct.pack("<HHII", tag, typ, count, offsets_at)
        elif tag == 279:
            ifd += struct.pack("<HHII", tag, typ, count, counts_at)
        elif typ == 3:
            ifd += struct.pack("<HHIHH", tag, typ, count, value, 0)
        else:
            ifd += struct.pack("<HHII", tag, typ, count, value)
    ifd += struct.pack("<I", 0)
    offsets = struct.pack(f"<{n}I", *(data_at + i * len(strip) for i in range(n)))
    counts = struct.pack(f"<{n}I", *([len(strip)] * n))
    path.write_bytes(b"II*\x00" + struct.pack("<I", 8) + ifd + offsets + counts + strip * n)


def test_bomb_tiff_is_what_it_claims(tmp_path: Path) -> None:
    """The crafted file is a valid TIFF of 60000x60000 in 3.6 MB (read lazily, page header)."""
    path = tmp_path / "bomb.tif"
    _bomb_tiff(path)
    assert 3.4e6 < path.stat().st_size < 3.8e6
    with tifffile.TiffFile(path) as tif:
        page = tif.pages.first
        assert page.shape == (60000, 60000) and page.dtype == np.uint8
        # a strip decodes: the file is genuine, not merely a damaged header
        tif.filehandle.seek(page.dataoffsets[0])
        strip = page.decode(tif.filehandle.read(page.databytecounts[0]), 0)
        assert strip[0].size == 1000 * 60000 and not strip[0].any()


_MEASURE = textwrap.dedent(
    """
    import resource, sys, time
    resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))  # a regression fails, not swaps
    from hdrfringe.errors import CaptureFormatError
    from hdrfringe.io.captures import read_capture_folder
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t0 = time.perf_counter()
    try:
        read_capture_folder(sys.argv[1])
        message = "accepted"
    except CaptureFormatError as exc:
        message = str(exc)
    seconds = time.perf_counter() - t0
    grown = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before
    print(f"{seconds} {grown}")
    print(message)
    """
)


@pytest.mark.parametrize("where", ["image", "map"])
def test_huge_declared_tiff_is_refused_from_its_header(
    capture_folder: Path, tmp_path: Path, where: str
) -> None:
    """A 3.6 MB TIFF declaring 60000x60000, as a capture image or as the truth map, is refused
    in under 1 s and under 200 MB of memory growth (the old reader decoded 3.6 GB first)."""
    m = _manifest(capture_folder)
    if where == "image":
        m["frames"][0]["file"] = "bomb.tif"
        _bomb_tiff(capture_folder / "bomb.tif")
    else:
        m["maps"] = {"truth_height_mm": "truth.tiff"}
        _bomb_tiff(capture_folder / "truth.tiff", bits=32, sample_format=3)
    _write_manifest(capture_folder, m)
    res = subprocess.run(
        [sys.executable, "-c", _MEASURE, str(capture_folder)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == 0, res.stderr
    timing, message = res.stdout.splitlines()
    seconds, grown_kb = (float(v) for v in timing.split())
    assert "declares 60000x60000 = 3600000000 pixels" in message, message
    assert f"more than the limit of {MAX_IMAGE_PIXELS}" in message
    assert seconds < 1.0 and grown_kb < 200 * 1024, (seconds, grown_kb)
    _cli_refuses(capture_folder, "bomb.tif" if where == "image" else "truth.tiff")


def test_deep_nesting_is_refused_before_parsing(capture_folder: Path) -> None:
    """200 000 nested arrays (the standard parser's RecursionError) and just over the limit."""
    text = json.dumps(_manifest(capture_folder))
    deep = text.replace('"scene": {', '"scene": {"x": ' + "[" * 200_000 + "]" * 200_000 + ", ")
    _write_manifest(capture_folder, deep)
    with pytest.raises(CaptureFormatError) as exc:
        read_manifest(capture_folder)
    _one_line(exc, "manifest.json", f"nested more than {MAX_JSON_DEPTH} deep")
    _cli_refuses(capture_folder, "nested more than")
    # at the limit it parses; brackets inside strings do not count
    ok = '"scene": {"s": "[[[[", "x": ' + "[" * (MAX_JSON_DEPTH - 2) + "]" * (MAX_JSON_DEPTH - 2)
    _write_manifest(capture_folder, text.replace('"scene": {', ok + ", "))
    assert read_manifest(capture_folder)["scene"]["s"] == "[[[["
    over = '"scene": {"x": ' + "[" * (MAX_JSON_DEPTH - 1) + "]" * (MAX_JSON_DEPTH - 1)
    _write_manifest(capture_folder, text.replace('"scene": {', over + ", "))
    with pytest.raises(CaptureFormatError, match="nested more than"):
        read_manifest(capture_folder)


@pytest.mark.parametrize(
    ("field", "literal", "named"),
    [
        ('"steps": 4', '"steps": ' + "7" * 5000, "frames[0].steps"),  # int() digit limit
        ('"pitch": 8.0', '"pitch": 1' + "0" * 399, "frames[0].pitch"),  # float overflow
        ('"pitch": 8.0', '"pitch": 1.' + "0" * 4000, "frames[0].pitch"),
    ],
)
def test_overlong_numbers_are_refused_naming_the_field(
    capture_folder: Path, field: str, literal: str, named: str
) -> None:
    text = json.dumps(_manifest(capture_folder))
    assert field in text
    _write_manifest(capture_folder, text.replace(field, literal, 1))
    with pytest.raises(CaptureFormatError) as exc:
        read_manifest(capture_folder)
    _one_line(exc, f"field '{named}'", f"more than the limit of {MAX_NUMBER_DIGITS}")


def test_overlong_number_via_cli(capture_folder: Path) -> None:
    text = json.dumps(_manifest(capture_folder)).replace('"pitch": 8.0', '"pitch": 1' + "0" * 399)
    _write_manifest(capture_folder, text)
    _cli_refuses(capture_folder, "frames[0].pitch")


@pytest.mark.parametrize("key", ["focal_px", "standoff_mm"])
@pytest.mark.parametrize("literal", ["NaN", "Infinity", "-Infinity", "0"])
def test_camera_geometry_must_be_finite_and_positive(
    capture_folder: Path, key: str, literal: str
) -> None:
    text = json.dumps(_manifest(capture_folder))
    _write_manifest(
        capture_folder, text.replace('"camera": {', f'"camera": {{"{key}": {literal}, ')
    )
    with pytest.raises(CaptureFormatError) as exc:
        read_manifest(capture_folder)
    _one_line(exc, f"field '{key}' must be")


def test_manifest_size_and_frame_count_are_bounded(capture_folder: Path) -> None:
    text = json.dumps(_manifest(capture_folder))
    _write_manifest(capture_folder, text + " " * MAX_MANIFEST_BYTES)  # valid JSON, too big
    with pytest.raises(CaptureFormatError) as exc:
        read_manifest(capture_folder)
    _one_line(exc, f"more than the limit of {MAX_MANIFEST_BYTES}")
    m = json.loads(text)
    m["frames"] = [{"file": f"g{i}.png", "kind": "uniform", "level": 1} for i in range(10_001)]
    _write_manifest(capture_folder, m)
    with pytest.raises(CaptureFormatError) as exc:
        read_manifest(capture_folder)
    _one_line(exc, f"10001 frames, more than the limit of {MAX_PROGRAM_FRAMES}")


def test_folder_pixels_are_bounded_before_decoding(
    capture_folder: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The folder total comes from the headers: nothing is decoded when it is too large."""
    monkeypatch.setattr(io_captures, "MAX_FOLDER_PIXELS", 4 * 48 * 64)

    def no_decoding(*args: object) -> None:
        raise AssertionError("an image was decoded")

    monkeypatch.setattr(io_captures, "load_image", no_decoding)
    with pytest.raises(CaptureFormatError) as exc:
        read_capture_folder(capture_folder)
    _one_line(exc, "5 images of 64x48 are 15360 pixels, more than the limit of 12288")


def test_bad_truth_maps_are_one_line_errors_naming_the_file(capture_folder: Path) -> None:
    m = _manifest(capture_folder)
    m["maps"] = {"truth_height_mm": "truth.tiff"}
    _write_manifest(capture_folder, m)
    path = capture_folder / "truth.tiff"
    # intact header, corrupt deflate data (zlib.error inside the decoder): a map another tool
    # wrote compressed (hdrfringe's own maps are uncompressed, io.results.MAP_COMPRESSION)
    data = np.linspace(0, 1, 48 * 64, dtype=np.float32).reshape(48, 64)
    tifffile.imwrite(path, data, compression="zlib")
    with tifffile.TiffFile(path) as tif:
        start = tif.pages.first.dataoffsets[0]
    raw = bytearray(path.read_bytes())
    raw[start : start + 16] = b"\xff" * 16
    path.write_bytes(bytes(raw))
    with pytest.raises(CaptureFormatError) as exc:
        read_capture_folder(capture_folder)
    _one_line(exc, "truth.tiff: cannot read map 'truth_height_mm'")
    with pytest.raises(CaptureFormatError) as exc:
        read_map_tiff(path)
    _one_line(exc, "truth.tiff: cannot read the map")
    _cli_refuses(capture_folder, "truth.tiff")
    # not a TIFF at all, and truncated: read_map_tiff itself gives the one-line error
    for content in (b"P6\n2 2\n255\n" + bytes(12), path.read_bytes()[:60]):
        path.write_bytes(content)
        with pytest.raises(CaptureFormatError) as exc:
            read_map_tiff(path)
        _one_line(exc, "truth.tiff: cannot read the map")
    # wrong pixel type: refused from the header, named
    tifffile.imwrite(path, np.zeros((48, 64), np.complex64))
    with pytest.raises(CaptureFormatError) as exc:
        read_capture_folder(capture_folder)
    _one_line(exc, "truth.tiff: map holds complex64 values")


def test_containers_and_signs_of_images_are_checked(capture_folder: Path) -> None:
    m = _manifest(capture_folder)
    m["frames"][0]["file"] = "first.tif"
    _write_manifest(capture_folder, m)
    image = capture_folder / "first.tif"
    counts = np.full((48, 64), 100, np.int16)
    counts[5, 7] = -3
    tifffile.imwrite(image, counts)
    with pytest.raises(CaptureFormatError) as exc:
        read_capture_folder(capture_folder)
    _one_line(exc, "first.tif: values go down to -3; camera counts are never negative")
    counts[5, 7] = 3
    tifffile.imwrite(image, counts)  # signed but non-negative: accepted as before
    assert read_capture_folder(capture_folder).images[0, 5, 7] == 3
    # a 32-bit container is refused even when its values would fit the bit depth
    tifffile.imwrite(image, counts.astype(np.uint32))
    with pytest.raises(CaptureFormatError) as exc:
        read_capture_folder(capture_folder)
    _one_line(exc, "first.tif: image dtype uint32 is not an integer 8- or 16-bit container")
    _cli_refuses(capture_folder, "first.tif", "uint32")


@pytest.mark.parametrize("what", ["image", "map", "manifest"])
def test_symlinks_are_confined_to_the_folder(
    capture_folder: Path, tmp_path: Path, what: str
) -> None:
    m = _manifest(capture_folder)
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    if what == "image":
        name = m["frames"][0]["file"]
        (capture_folder / name).rename(outside / name)
        link = capture_folder / name
        link.symlink_to(outside / name)
    elif what == "map":
        m["maps"] = {"truth_height_mm": "truth.tiff"}
        _write_manifest(capture_folder, m)
        write_map_tiff(outside / "truth.tiff", np.zeros((48, 64)))
        link = capture_folder / "truth.tiff"
        link.symlink_to(outside / "truth.tiff")
    else:
        (capture_folder / "manifest.json").rename(outside / "manifest.json")
        link = capture_folder / "manifest.json"
        link.symlink_to(outside / "manifest.json")
    with pytest.raises(CaptureFormatError) as exc:
        read_capture_folder(capture_folder)
    _one_line(exc, f"{link}:", "outside the capture folder")
    # the same file reached by a symlink inside the folder is fine
    target = outside / link.name
    link.unlink()
    target.rename(capture_folder / f"real_{link.name}")
    link.symlink_to(f"real_{link.name}")
    read_capture_folder(capture_folder)
    if what == "image":
        _cli_refuses_after_escape(capture_folder, link, outside)


def _cli_refuses_after_escape(folder: Path, link: Path, outside: Path) -> None:
    real = folder / f"real_{link.name}"
    real.rename(outside / link.name)
    link.unlink()
    link.symlink_to(os.path.relpath(outside / link.name, folder))
    _cli_refuses(folder, link.name, "outside the capture folder")


def test_docs_list_every_reader_limit() -> None:
    """docs/capture_format.md's Limits section names each bound the reader checks."""
    docs = Path(__file__).resolve().parents[1] / "docs" / "capture_format.md"
    text = docs.read_text(encoding="utf-8")
    section = text[text.index("## Limits") : text.index("## In memory")]
    for name in (
        "MAX_MANIFEST_BYTES",
        "MAX_JSON_DEPTH",
        "MAX_NUMBER_DIGITS",
        "MAX_PROGRAM_FRAMES",
        "MAX_STEPS",
        "MAX_IMAGE_PIXELS",
        "MAX_FOLDER_PIXELS",
        "MAX_PROJECTOR_PIXELS",
    ):
        assert f"`{name}`" in section, name


def _png_header_only(path: Path, width: int, height: int) -> None:
    """A PNG whose header declares width x height 8-bit gray pixels and holds no pixel data."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        crc = zlib.crc32(kind + data)
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc)

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IEND", b""))


@pytest.mark.parametrize("side", [12000, 60000])  # under and over Pillow's own bomb limit
def test_huge_declared_png_is_refused_by_our_limit(
    capture_folder: Path, recwarn: pytest.WarningsRecorder, side: int
) -> None:
    name = _manifest(capture_folder)["frames"][0]["file"]
    _png_header_only(capture_folder / name, side, side)
    with pytest.raises(CaptureFormatError) as exc:
        read_capture_folder(capture_folder)
    _one_line(exc, name, "declares", "more than", str(MAX_IMAGE_PIXELS))
    assert not recwarn.list  # Pillow's decompression-bomb warning is not shown


@pytest.mark.parametrize("depth", [40, 5000])
def test_deep_toml_is_refused_whatever_the_recursion_limit(tmp_path: Path, depth: int) -> None:
    """A host program (mypy in the test process does) may raise the recursion limit so far that
    the parser reads a 5000-deep array: the nesting is still refused, counted explicitly."""
    from hdrfringe.io._read_limits import MAX_TOML_DEPTH, load_toml_bounded

    p = tmp_path / "deep.toml"
    p.write_text("a = " + "[" * depth + "]" * depth)
    kw = dict(what="rig configuration", max_bytes=50_000, holds="holds settings only",
              doc="docs/hardware.md", missing="give the file")  # fmt: skip
    old = sys.getrecursionlimit()
    sys.setrecursionlimit(max(old, 4 * depth + 1000))
    try:
        with pytest.raises(InputError, match="nested too deep"):
            load_toml_bounded(p, **kw)
    finally:
        sys.setrecursionlimit(old)
    p.write_text("a = " + "[" * MAX_TOML_DEPTH + "]" * MAX_TOML_DEPTH)  # the deepest accepted
    assert "a" in load_toml_bounded(p, **kw)
