"""Hostile and odd inputs of issue 31 (its readers half): one line and exit 2, never a traceback,
a hang or an unbounded allocation; valid inputs the audit found refused now accepted.

Each test is built from the audit's reproducer of one root cause (the number in its name):
3 correction files unchecked, 4 small files declaring huge arrays, 5 FIFOs given as files,
7 gamma captures refused by ``phase``, 8 LZW TIFFs, 10 manifests and odd paths, 12 library
arguments, and the import regular expression with catastrophic backtracking.
"""

from __future__ import annotations

import io
import json
import os
import zipfile
from pathlib import Path

import h5py
import numpy as np
import pytest

from hdrfringe.core.calibration import Calibration
from hdrfringe.core.saturation.estimate import CorrectionPolynomial
from hdrfringe.errors import InputError
from hdrfringe.io.calibration_file import save_calibration
from tests.conftest import run_cli


def _refused(res: object, out: Path | None, *needles: str) -> str:
    """One ``error:`` line naming every needle, exit 2, no traceback, nothing written."""
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]  # type: ignore[attr-defined]
    assert res.returncode == 2 and len(lines) == 1, res.stderr  # type: ignore[attr-defined]
    assert lines[0].startswith("error:") and "Traceback" not in res.stderr  # type: ignore
    for needle in needles:
        assert needle in lines[0], lines[0]
    assert out is None or not out.exists()
    return lines[0]


# --- 3: DPA correction files ----------------------------------------------------------------


@pytest.mark.parametrize(
    ("change", "needles"),
    [
        ({"coefficients": [float("nan"), 1.0]}, ["'coefficients'", "not finite"]),
        ({"domain": [255.0, float("inf")]}, ["'domain'", "not finite"]),
        ({"bit_depth": 99}, ["'bit_depth'", "1..16", "train-correction"]),
        ({"window": [1.0, -1.0]}, ["'window'", "lo < hi"]),
    ],
)
def test_3_correction_values_checked(tmp_path: Path, change: dict, needles: list[str]) -> None:
    """With coefficients [NaN, 1] DPA captured 550 sets instead of 193 (every estimate NaN)."""
    good = CorrectionPolynomial((0.5, 1.0), (255.0, 355.0)).save(tmp_path / "good.json")
    data = json.loads(good.read_text())
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({**data, **change}))  # NaN and Infinity as json.dumps writes them
    with pytest.raises(InputError, match=needles[0]):
        CorrectionPolynomial.load(bad)
    out = tmp_path / "out"
    res = run_cli("measure", "--rig", "sim", "--strategy", "dpa", "--correction", str(bad),
                  "-o", str(out))  # fmt: skip
    _refused(res, out, str(bad), *needles)


@pytest.mark.parametrize("kind", ["fifo", "folder", "nested"])
def test_5_10_correction_path_not_a_json_file(tmp_path: Path, kind: str) -> None:
    """A FIFO hung forever, a folder (IsADirectoryError) and JSON nested 100000 deep
    (RecursionError) gave tracebacks."""
    path = tmp_path / "c.json"
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "folder":
        path.mkdir()
    else:
        path.write_text("[" * 100_000 + "]" * 100_000)
    needle = {"fifo": "is a FIFO", "folder": "is a folder", "nested": "nested too deep"}[kind]
    out = tmp_path / "out"
    res = run_cli("measure", "--rig", "sim", "--strategy", "dpa", "--correction", str(path),
                  "-o", str(out))  # fmt: skip
    _refused(res, out, needle)


# --- 4 and 5: calibration files -------------------------------------------------------------


@pytest.fixture
def small_calibration(tmp_path: Path) -> Path:
    """A 48x64 linear calibration file of a few KB."""
    cal = Calibration("linear", np.full((48, 64), 0.5), None, np.zeros((48, 64)),
                      np.array([2.0, 4.0]), border_px=0)  # fmt: skip
    return save_calibration(tmp_path / "cal.h5", cal)


@pytest.mark.parametrize("declare_size", [False, True])
def test_4_calibration_declaring_a_huge_k_map(
    tmp_path: Path, small_calibration: Path, capture_folder: Path, declare_size: bool
) -> None:
    """A few KB declaring a 100000x100000 float64 k_map: "Unable to allocate 74.5 GiB"."""
    with h5py.File(small_calibration, "r+") as f:
        del f["k_map"]
        f.create_dataset("k_map", shape=(100_000, 100_000), dtype="f8", chunks=(64, 64))
        if declare_size:  # the image size attributes agree with the huge map
            f.attrs["image_height"] = f.attrs["image_width"] = 100_000
    assert small_calibration.stat().st_size < 64_000
    out = tmp_path / "out"
    res = run_cli("measure", str(capture_folder), "-c", str(small_calibration), "-o", str(out))
    needle = "image size 100000 x 100000" if declare_size else "/k_map declares shape"
    _refused(res, out, str(small_calibration), needle, "recalibrate")


def test_5_calibration_fifo(tmp_path: Path, capture_folder: Path) -> None:
    """``measure -c FIFO`` hung forever in h5py's open."""
    fifo = tmp_path / "cal.h5"
    os.mkfifo(fifo)
    out = tmp_path / "out"
    res = run_cli("measure", str(capture_folder), "-c", str(fifo), "-o", str(out))
    _refused(res, out, str(fifo), "is a FIFO")


def _npz_member(shape: tuple[int, ...]) -> bytes:
    """An .npy header declaring ``shape`` with no data after it."""
    buf = io.BytesIO()
    header = {"descr": "<f8", "fortran_order": False, "shape": shape}
    np.lib.format.write_array_header_1_0(buf, header)
    return buf.getvalue()


def test_4_5_stereo_from_huge_npz_and_fifo(tmp_path: Path) -> None:
    """A 2 KB stereo_params.npz whose Kc declares 30000x30000 allocated 6.7 GiB; a FIFO given
    to ``--from`` hung."""
    npz = tmp_path / "stereo_params.npz"
    with zipfile.ZipFile(npz, "w") as z:
        z.writestr("Kc.npy", _npz_member((30_000, 30_000)))
        for key in ("dist_c", "Kp", "dist_p", "R", "T"):
            buf = io.BytesIO()
            np.save(buf, np.eye(3))
            z.writestr(f"{key}.npy", buf.getvalue())
    out = tmp_path / "st.h5"
    res = run_cli("calibrate-stereo", "--from", str(npz), "--camera-size", "640x480",
                  "--projector-size", "912x1140", "-o", str(out))  # fmt: skip
    _refused(res, out, "'Kc' declares shape 30000x30000")
    fifo = tmp_path / "calib.yml"
    os.mkfifo(fifo)
    _refused(run_cli("calibrate-stereo", "--from", str(fifo), "-o", str(out)), out, "is a FIFO")


# --- 10: manifests and odd paths ------------------------------------------------------------


def _edit_manifest(folder: Path, edit: object) -> None:
    path = folder / "manifest.json"
    manifest = json.loads(path.read_text())
    edit(manifest)  # type: ignore[operator]
    path.write_text(json.dumps(manifest))


@pytest.mark.parametrize(
    ("edit", "needles"),
    [
        (lambda m: m["frames"][0].update(file="a\x00b.png"), ["frame 0", "NUL byte"]),
        (lambda m: m["camera"].update(bit_depth=12), ["8-bit image", "camera.bit_depth is 12"]),
        (lambda m: m["camera"].update(gain_dn_per_e=-1.0), ["camera: field 'gain_dn_per_e'"]),
        (
            lambda m: m["camera"].update(read_noise_dn=-1.0, gain_dn_per_e=0.01),
            ["camera: field 'read_noise_dn' must be >= 0"],
        ),
    ],
    ids=["nul", "12-bit-over-8-bit", "negative-gain", "negative-read-noise"],
)
def test_10_manifest_values(
    tmp_path: Path, capture_folder: Path, edit: object, needles: list[str]
) -> None:
    """A NUL byte gave a ValueError traceback; a 12-bit manifest over 8-bit PNGs (clipping at
    255) counted no saturated pixel; a negative gain was accepted, a negative read noise refused
    by a message naming no manifest field."""
    _edit_manifest(capture_folder, edit)
    out = tmp_path / "out"
    _refused(run_cli("phase", str(capture_folder), "-o", str(out)), out, *needles)


def test_10_unreadable_manifest(
    tmp_path: Path, capture_folder: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``chmod 000 manifest.json`` gave a PermissionError traceback (simulated: the suite may
    run as root, which reads any file)."""
    real_open = Path.open

    def deny(self: Path, *args: object, **kwargs: object) -> object:
        if self.name == "manifest.json":
            raise PermissionError(13, "Permission denied", str(self))
        return real_open(self, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(Path, "open", deny)
    out = tmp_path / "out"
    res = run_cli("phase", str(capture_folder), "-o", str(out))
    needle = "manifest.json: cannot read the file (Permission denied, errno EACCES)"
    _refused(res, out, needle, "chmod")


def test_10_import_description_is_a_folder(tmp_path: Path, capture_folder: Path) -> None:
    """``import -d FOLDER`` said the description "does not exist"."""
    out, desc = tmp_path / "out", tmp_path / "desc.toml"
    desc.mkdir()
    res = run_cli("import", str(capture_folder), "-d", str(desc), "-o", str(out))
    _refused(res, out, f"{desc}: is a folder, not a description file")


# --- 8: LZW-compressed TIFF captures --------------------------------------------------------


def _lzw_folder(capture_folder: Path) -> Path:
    """The capture folder with every PNG re-saved as an LZW-compressed TIFF."""
    import imageio.v3 as iio
    import tifffile

    manifest = json.loads((capture_folder / "manifest.json").read_text())
    for frame in manifest["frames"]:
        png = capture_folder / frame["file"]
        tifffile.imwrite(png.with_suffix(".tif"), iio.imread(png), compression="lzw")
        png.unlink()
        frame["file"] = png.with_suffix(".tif").name
    (capture_folder / "manifest.json").write_text(json.dumps(manifest))
    return capture_folder


def test_8_lzw_tiff_captures_read(tmp_path: Path, capture_folder: Path) -> None:
    """LZW TIFFs were called "corrupt or truncated: recapture" (the codec package was missing);
    decoded, they give the PNG folder's phase bit for bit."""
    from hdrfringe.core.decode import decode_captures
    from hdrfringe.io.captures import read_capture_folder

    png = decode_captures(read_capture_folder(capture_folder)).primary
    lzw = _lzw_folder(capture_folder)
    out = tmp_path / "out"
    res = run_cli("phase", str(lzw), "-o", str(out))
    assert res.returncode == 0, res.stderr
    got = decode_captures(read_capture_folder(lzw)).primary
    assert png is not None and got is not None
    np.testing.assert_array_equal(got.unwrapped_phase, png.unwrapped_phase)


def test_8_lzw_without_the_codec_names_it(tmp_path: Path, capture_folder: Path) -> None:
    """Where imagecodecs is missing, the message names it and how to install it, not damage
    (a new interpreter: tifffile binds the codec package when it is imported)."""
    import subprocess
    import sys

    lzw = _lzw_folder(capture_folder)
    out = tmp_path / "out"
    code = (
        "import sys; sys.modules['imagecodecs'] = None\n"
        "from hdrfringe.cli import app\n"
        f"app(['phase', {str(lzw)!r}, '-o', {str(out)!r}], prog_name='hdrfringe')\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120, env={**os.environ, "COLUMNS": "400"})  # fmt: skip
    line = _refused(res, out, "LZW", "requires the 'imagecodecs' package, which is not installed")
    assert "pip install 'imagecodecs>=" in line and "corrupt" not in line


# --- 4: a folder within the pixel limits whose decode does not fit; a huge loop camera -------


def _png_of_zeros(path: Path, width: int, height: int, rows: int) -> None:
    """An 8-bit gray PNG of zeros, compressed once per block of ``rows`` rows and repeated (a
    full flush makes each block's deflate bytes identical): 11585x11585 in about 0.1 s."""
    import struct
    import zlib

    assert height % rows == 0
    block = b"\x00" * ((width + 1) * rows)  # filter byte 0 and the row's pixels
    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    deflated = c.compress(block) + c.flush(zlib.Z_FULL_FLUSH)
    tail = zlib.compressobj(9, zlib.DEFLATED, -15).flush(zlib.Z_FINISH)
    adler = 1
    for _ in range(height // rows):
        adler = zlib.adler32(block, adler)
    data = b"\x78\xda" + deflated * (height // rows) + tail + struct.pack(">I", adler)

    def chunk(kind: bytes, body: bytes) -> bytes:
        crc = zlib.crc32(kind + body)
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", crc)

    header = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", data)
                     + chunk(b"IEND", b""))  # fmt: skip


@pytest.mark.parametrize(
    "command", [["phase"], ["measure"], ["gamma"], ["calibrate", "--model", "linear"]]
)
def test_4_folder_needing_more_memory_than_available(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, command: list[str]
) -> None:
    """Four 11585x11585 PNGs (632 KB together, each within MAX_IMAGE_PIXELS, together within
    MAX_FOLDER_PIXELS) needed more than 4 GiB in ``phase``: refused from the headers, saying
    how much they need, on a machine with 4 GiB free (nothing decoded: the test takes < 1 s),
    by every command that decodes a folder."""
    import shutil

    import hdrfringe.io._read_limits as read_limits
    from hdrfringe.core.limits import MAX_FOLDER_PIXELS, MAX_IMAGE_PIXELS
    from hdrfringe.core.patterns import FringeSpec
    from hdrfringe.io.captures import DECODE_BYTES_PER_PIXEL

    side = 11585
    assert side * side <= MAX_IMAGE_PIXELS and 4 * side * side <= MAX_FOLDER_PIXELS
    folder = tmp_path / "big"
    folder.mkdir()
    _png_of_zeros(folder / "i0.png", side, side, rows=331)
    frames = []
    for k, frame in enumerate(FringeSpec("sinusoidal", 4, 16.0).frames()):
        if k:
            shutil.copyfile(folder / "i0.png", folder / f"i{k}.png")
        frames.append(frame.manifest_entry(f"i{k}.png"))
    manifest = {"format": "hdrfringe-captures", "version": 1, "camera": {"bit_depth": 8},
                "frames": frames}  # fmt: skip
    (folder / "manifest.json").write_text(json.dumps(manifest))
    assert sum(p.stat().st_size for p in folder.iterdir()) < 700_000
    monkeypatch.setattr(read_limits, "available_memory", lambda: 4 << 30)
    out = tmp_path / "out"
    need = 4 * side * side * (1 + DECODE_BYTES_PER_PIXEL) / (1 << 30)  # 10.0 GiB
    line = _refused(run_cli(command[0], str(folder), *command[1:], "-o", str(out)), out,
                    f"4 images of {side}x{side} need at least {need:.1f} GiB of memory to decode",
                    "4.0 GiB is available")  # fmt: skip
    assert f"{need:.1f}" == "10.0" and "split the captures" in line  # docs/capture_format.md


def test_4_calibrate_counts_every_plate_folder_it_holds(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``calibrate`` reads all its plate folders (26 in a typical series) before decoding one,
    but each was checked alone: 26 folders of four 4000x4000 images, each needing 1.2 GiB to
    decode, passed on a machine with 4 GiB free and together needed 5.8 GiB. Refused from the
    headers now, naming the count; no image is decoded (a broken check fails at once)."""
    import hdrfringe.io._read_limits as read_limits
    import hdrfringe.io.captures as captures
    from hdrfringe.core.patterns import FringeSpec
    from hdrfringe.io.captures import DECODE_BYTES_PER_PIXEL

    side, count = 4000, 26
    _png_of_zeros(tmp_path / "zeros.png", side, side, rows=400)
    spec = FringeSpec("sinusoidal", 4, 16.0)
    frames = [f.manifest_entry(f"i{k}.png") for k, f in enumerate(spec.frames())]
    for n in range(count):
        folder = tmp_path / "S" / f"plate_{n:02d}"
        folder.mkdir(parents=True)
        for k in range(4):
            os.link(tmp_path / "zeros.png", folder / f"i{k}.png")
        manifest = {"format": "hdrfringe-captures", "version": 1, "camera": {"bit_depth": 8},
                    "frames": frames, "scene": {"depth_mm": float(n)}}  # fmt: skip
        (folder / "manifest.json").write_text(json.dumps(manifest))

    def no_decoding(*args: object) -> None:
        raise AssertionError("an image was decoded")

    monkeypatch.setattr(read_limits, "available_memory", lambda: 4 << 30)
    monkeypatch.setattr(captures, "load_image", no_decoding)
    pixels = 4 * side * side  # one folder's image pixels, 8-bit
    one = pixels * (1 + DECODE_BYTES_PER_PIXEL) / (1 << 30)
    held = (count * pixels + pixels * DECODE_BYTES_PER_PIXEL + count * side * side * 8) / (1 << 30)
    assert f"{one:.1f} {held:.1f}" == "1.2 5.8"  # each alone fits in 4 GiB; together not
    out = tmp_path / "cal.h5"
    line = _refused(run_cli("calibrate", str(tmp_path / "S"), "-o", str(out)), out,
                    f"{count} folders of {side}x{side} images held together need at least "
                    f"{held:.1f} GiB of memory to decode", "4.0 GiB is available")  # fmt: skip
    assert "plate_00 and 25 more folders" in line and "use fewer folders" in line


def test_4_loop_camera_size_bounded(tmp_path: Path) -> None:
    """``--camera 'loop:plate?size=100000x100000'`` allocated 9.3 GiB: refused when parsed,
    before a display or a rig is made."""
    from hdrfringe.hardware.loop_camera import parse_loop_spec

    with pytest.raises(InputError, match="size must be WIDTHxHEIGHT of at most 134217728"):
        parse_loop_spec("loop:plate?size=100000x100000")
    assert parse_loop_spec("loop:plate?size=11585x11585").size == (11585, 11585)
    camera = "loop:plate?size=100000x100000"
    res = run_cli("measure", "--rig", "hardware", "--projector", "screen:0@:4999",
                  "--camera", camera, "-o", str(tmp_path / "o"))  # fmt: skip
    _refused(res, tmp_path / "o", "size='100000x100000' is not valid")


# --- 12: library arguments ------------------------------------------------------------------


def test_12_saturation_count_does_not_wrap() -> None:
    """256 saturated images counted 0 in a uint8 accumulator (up to MAX_STEPS are allowed)."""
    import hdrfringe as hf

    stack = np.full((300, 2, 3), 255, np.uint8)
    stack[:44, 0, 0] = 3  # 256 saturated at (0, 0)
    count = hf.saturation_count(stack, 8)
    assert count[0, 0] == 256 and count[1, 2] == 300
    assert hf.saturation_count(stack[:255], 8).dtype == np.uint8  # unchanged up to 255 images


@pytest.mark.parametrize(
    ("call", "needles"),
    [
        (lambda hf: hf.precompensate_gamma([np.nan, 3.0]), ["gray holds 1 non-finite", "nan"]),
        (
            lambda hf: hf.modify_captures(
                np.zeros((2, 2), np.uint8), 8, add_lux=100, dn_per_lux=-1
            ),
            ["dn_per_lux must be", "got -1"],
        ),
        (lambda hf: hf.FringeSpec(pitch_px="8"), ["FringeSpec pitch_px must be a number", "'8'"]),
        (
            lambda hf: hf.decode_set(np.zeros((4, 8, 8), np.uint8), None, 8),
            ["spec must be a FringeSpec", "None"],
        ),
    ],
    ids=["gamma-nan", "negative-dn-per-lux", "pitch-as-text", "spec-none"],
)
def test_12_library_arguments_named(call: object, needles: list[str]) -> None:
    """NaN was sent as gray 0, dn_per_lux=-1 darkened, a text pitch and spec=None raised a
    TypeError/AttributeError naming no argument."""
    import hdrfringe as hf

    with pytest.raises(InputError) as err:
        call(hf)  # type: ignore[operator]
    for needle in needles:
        assert needle in str(err.value)


def test_12_predict_phase_std_images_of_another_size() -> None:
    import hdrfringe as hf
    from hdrfringe.core.uncertainty import NoiseModel, predict_phase_std

    spec = hf.FringeSpec("sinusoidal", 4, 8.0)
    images = np.random.default_rng(0).integers(40, 200, (4, 8, 8)).astype(np.uint8)
    res = hf.decode_set(images, spec, 8)
    predict_phase_std(res, NoiseModel(1.0), images=images, bit_depth=8)
    with pytest.raises(InputError, match=r"images of shape \(4, 9, 9\) are not the decoded"):
        predict_phase_std(res, NoiseModel(1.0), images=np.zeros((4, 9, 9), np.uint8), bit_depth=8)


def test_12_measure_with_a_calibration_path() -> None:
    """``hf.measure(rig, "cal.h5")`` said the rig needs specs, not that the path is no
    calibration."""
    import hdrfringe as hf

    rig = hf.virtual_rig("white_plate", resolution=(64, 48))
    with pytest.raises(InputError, match=r"calibration must be .* got str 'cal.h5'; load the"):
        hf.measure(rig, "cal.h5", specs=[hf.FringeSpec("sinusoidal", 4, 8.0)])


# --- the import regular expression with catastrophic backtracking ---------------------------


def test_import_regex_backtracking_bounded(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``regex = '(a|aa)+b'`` over a 40-character file name ran for minutes with re
    (exponential in the name's length); the regex module's timeout refuses it after the
    budget (REGEX_SECONDS, 2 s; 0.25 s here to keep the test short) with one line naming the
    expression and the file."""
    import time

    import hdrfringe.io.import_description as description
    import hdrfringe.io.importer as importer

    assert description.REGEX_SECONDS == importer.REGEX_SECONDS == 2.0
    for module in (description, importer):
        monkeypatch.setattr(module, "REGEX_SECONDS", 0.25)
    images = tmp_path / "images"
    images.mkdir()
    (images / ("a" * 40 + ".png")).write_bytes(b"")
    desc = tmp_path / "d.toml"
    desc.write_text(
        "[camera]\nbit_depth = 8\n[[uniform]]\nregex = '(a|aa)+b'\nlevel = 'white'\n"
    )
    out = tmp_path / "out"
    start = time.monotonic()
    res = run_cli("import", str(images), "-d", str(desc), "-o", str(out))
    took = time.monotonic() - start
    _refused(res, out, "'(a|aa)+b' takes more than 0.25 s", "a" * 40 + ".png", "nested repeats")
    assert 0.25 <= took < 2.0, took  # the regex module checks its clock coarsely
