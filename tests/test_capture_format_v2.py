"""Capture format version 2 (docs/capture_format.md): 2-D frames in side files, per-frame gain.

Version-1 folders written before version 2 existed (tests/data/capture_v1, see its README) must
read exactly as before and be written again identically; version-2 folders must round-trip every
frame, image and setting; hostile side files must fail in one line before any output is written.
"""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest
import tifffile

from hdrfringe.core.captures import CameraSettings, Captures, ProjectorInfo, group_fringe_sets
from hdrfringe.core.decode import decode_captures
from hdrfringe.core.frames import (
    CenterlineFrame,
    FringeFrame,
    ImageFrame,
    PixelwiseFringeFrame,
    UniformFrame,
    render_frame,
)
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import CaptureFormatError
from hdrfringe.io.captures import read_capture_folder, read_manifest, write_capture_folder
from hdrfringe.io.pattern_folder import write_pattern_folder
from hdrfringe.rig.scenes import white_plate
from hdrfringe.rig.simulated import CameraModel, SimulatedRig
from tests.conftest import run_cli

DATA = Path(__file__).parent / "data"
PROJ = ProjectorInfo(32, 24, 8, 2.2)
SHAPE = (5, 7)  # camera image (H, W)
SPEC = FringeSpec("sinusoidal", 3, 6.0, "vertical", 40, 255)
TWO_PI = 2 * np.pi


def _map(seed: int, lo: float = 60.0, hi: float = 250.0) -> np.ndarray:
    """A MIGL map with fractional values (float32 survives, 8-bit PNG would not)."""
    return np.random.default_rng(seed).uniform(lo, hi, (PROJ.height, PROJ.width))


def _v2_captures() -> Captures:
    """Two pixelwise sets (two maps, two exposures), image frames whole and fractional, a line
    set with a gain, a uniform frame with a gain, a centerline without settings."""
    map_a, map_b = _map(1), _map(2)
    whole = np.zeros((PROJ.height, PROJ.width))
    whole[::2, ::3] = 255.0
    frac = np.linspace(0, 200.5, PROJ.width * PROJ.height).reshape(PROJ.height, PROJ.width)
    frames = [
        *[PixelwiseFringeFrame(SPEC, i, map_a) for i in (2, 0, 1)],  # any order
        *[PixelwiseFringeFrame(SPEC, i, map_b) for i in range(3)],
        ImageFrame(whole, "markers"),
        ImageFrame(frac, "ramp"),
        *SPEC.frames(),
        UniformFrame(128),
        CenterlineFrame(12.0),
    ]
    n = len(frames)
    images = np.random.default_rng(0).integers(0, 4096, (n, *SHAPE)).astype(np.uint16)
    return Captures(
        frames,
        images,
        12,
        projector=PROJ,
        camera={"focal_px": 900.0},
        scene={"depth_mm": 0.0},
        exposure_ms=[8.0] * 3 + [16.0] * 3 + [16.0, None] + [16.0] * 3 + [4.0, None],
        gain_db=[0.0] * 3 + [None] * 3 + [None, 2.5] + [6.0] * 3 + [-3.0, None],
        maps={"truth_height_mm": np.ones(SHAPE, np.float32)},
        name="v2",
    )


def _edit_manifest(folder: Path, edit) -> None:
    m = json.loads((folder / "manifest.json").read_text())
    edit(m)
    (folder / "manifest.json").write_text(json.dumps(m))


def _one_line_error(folder: Path, *needles: str) -> str:
    with pytest.raises(CaptureFormatError) as info:
        read_capture_folder(folder)
    msg = str(info.value)
    assert "\n" not in msg
    for needle in needles:
        assert needle in msg, msg
    return msg


# --- writing: which version, which files ----------------------------------------------------


def test_version_follows_what_the_captures_need(tmp_path: Path) -> None:
    """Line frames with exposures stay version 1 (no gain field, no projector/ folder); a gain
    or a 2-D frame makes version 2. Rejects a writer that always writes 2 (or always 1)."""
    images = np.zeros((4, *SHAPE), np.uint8)
    frames = [*SPEC.frames(), UniformFrame(10)]
    v1 = Captures(frames, images, 8, projector=PROJ, exposure_ms=[5.0, 5.0, 5.0, 2.0])
    gained = dataclasses.replace(v1, gain_db=[None, None, None, 6.0])
    pixelwise = Captures(
        [PixelwiseFringeFrame(SPEC, i, _map(1)) for i in range(3)], images[:3], 8, projector=PROJ
    )
    assert (v1.format_version, gained.format_version, pixelwise.format_version) == (1, 2, 2)
    for caps, version in ((v1, 1), (gained, 2), (pixelwise, 2)):
        out = write_capture_folder(tmp_path / f"c{id(caps)}", caps)
        m = json.loads((out / "manifest.json").read_text())
        assert m["version"] == version
        assert (out / "projector").exists() == (caps is pixelwise)
    m = read_manifest(tmp_path / f"c{id(gained)}")
    assert m["frames"][3]["gain_db"] == 6.0 and "gain_db" not in m["frames"][0]


def test_v2_round_trip_keeps_frames_images_and_settings(tmp_path: Path) -> None:
    """Write -> read gives equal frames (by key: spec, shift, map digest), images, exposures,
    gains, sets and maps; each distinct 2-D content is one side file (2 maps + 2 images for 8
    frames); whole images are 8-bit PNG at an 8-bit projector, fractional ones float32 TIFF."""
    caps = _v2_captures()
    out = write_capture_folder(tmp_path / "caps", caps)
    m = json.loads((out / "manifest.json").read_text())
    assert m["version"] == 2
    side = sorted(p.relative_to(out).as_posix() for p in (out / "projector").iterdir())
    assert len(side) == 4
    maps = [m["frames"][i]["migl_map"] for i in range(6)]
    assert len(set(maps[:3])) == 1 and len(set(maps[3:])) == 1 and len(set(maps)) == 2
    assert {*maps, m["frames"][6]["image"], m["frames"][7]["image"]} == set(side)

    back = read_capture_folder(out)
    assert [f.key() for f in back.frames[:8]] == [f.key() for f in caps.frames[:8]]
    assert back.frames == caps.frames
    np.testing.assert_array_equal(back.images, caps.images)
    assert back.exposure_ms == caps.exposure_ms and back.gain_db == caps.gain_db
    assert back.projector == caps.projector and back.camera == caps.camera
    assert back.sets == caps.sets
    assert [(s.label, s.frame_indices, s.gain_db) for s in back.sets] == [
        (f"s3_p6_v_i40_g255_map{caps.frames[0].content_sha256[:8]}_e8_gain0dB", (1, 2, 0), 0.0),
        (f"s3_p6_v_i40_g255_map{caps.frames[3].content_sha256[:8]}_e16", (3, 4, 5), None),
        ("s3_p6_v_i40_g255_e16_gain6dB", (8, 9, 10), 6.0),
    ]
    for a, b in zip(back.frames, caps.frames, strict=True):
        if isinstance(a, PixelwiseFringeFrame | ImageFrame):
            assert a.data.dtype == np.float32
            np.testing.assert_array_equal(a.data, b.data)
    assert back.content_hash() == caps.content_hash()

    markers = iio.imread(out / m["frames"][6]["image"])
    assert m["frames"][6]["image"].endswith(".png") and markers.dtype == np.uint8
    np.testing.assert_array_equal(markers, caps.frames[6].data)
    ramp = tifffile.imread(out / m["frames"][7]["image"])
    assert m["frames"][7]["image"].endswith(".tiff") and ramp.dtype == np.float32


def test_image_side_files_follow_the_projector_bit_depth(tmp_path: Path) -> None:
    """At a 16-bit projector the PNG is 16-bit even when the levels would fit 8 bits."""
    proj16 = ProjectorInfo(PROJ.width, PROJ.height, 16, 1.0)
    frame = ImageFrame(np.full((PROJ.height, PROJ.width), 200.0), "gray")
    caps = Captures([frame], np.zeros((1, *SHAPE), np.uint8), 8, projector=proj16)
    out = write_capture_folder(tmp_path / "caps", caps)
    stored = iio.imread(out / frame.default_data_file())
    assert stored.dtype == np.uint16 and stored.max() == 200
    assert read_capture_folder(out).frames == [frame]


def test_a_failing_write_leaves_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A failure while side files are written (after the camera images) leaves no folder and no
    staging folder behind."""
    import hdrfringe.io.captures as io_captures

    def broken(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(io_captures, "write_map_tiff", broken)
    with pytest.raises(OSError, match="disk full"):
        write_capture_folder(tmp_path / "caps", _v2_captures())
    assert list(tmp_path.iterdir()) == []


# --- version 1 keeps reading and writing as before ------------------------------------------


def _v1_reference() -> Captures:
    """The captures tests/data/capture_v1 was written from (tests/data/README.md)."""
    spec = FringeSpec("sinusoidal", 3, 8.0)
    rng = np.random.default_rng(10)
    images = rng.integers(0, 4096, size=(8, 4, 6)).astype(np.uint16)
    return Captures(
        [*spec.frames(), *spec.frames(), CenterlineFrame(20.0), UniformFrame(128)],
        images,
        12,
        projector=ProjectorInfo(800, 600, 8, 2.2),
        camera={"focal_px": 1000.0, "standoff_mm": 500.0},
        scene={"depth_mm": 4.0, "name": "plate"},
        exposure_ms=[5.0] * 3 + [20.0] * 3 + [7.5, None],
        set_labels=["short"] * 3 + ["long"] * 3 + [None, None],
        gamma_precompensation=[None] * 3 + [1.5] * 3 + [None, None],
        maps={"truth_height_mm": np.linspace(0, 4, 24, dtype=np.float32).reshape(4, 6)},
    )


def test_v1_folder_from_before_version_2_reads_as_before() -> None:
    """The folder's content hash is the one the pre-version-2 code computed (README), and it
    equals the captures it was written from."""
    back = read_capture_folder(DATA / "capture_v1")
    ref = _v1_reference()
    assert back.content_hash() == (
        "deacd532a9987a9de9fa431007b045333fa128f8fb6b6db234605fcd65386307"
    )
    assert back.content_hash() == ref.content_hash()
    assert back.frames == ref.frames and back.sets == ref.sets
    assert back.gain_db == (None,) * 8 and back.format_version == 1
    assert [s.label for s in back.sets] == ["short", "long"]


def test_v1_captures_are_written_as_before(tmp_path: Path) -> None:
    """Writing the same captures today gives the same manifest, byte for byte, and the same
    files with the same content (PNG/TIFF bytes depend on the encoder library's version)."""
    out = write_capture_folder(tmp_path / "caps", _v1_reference(), extra={"lab": "B2"})
    ref = DATA / "capture_v1"
    assert sorted(p.name for p in out.iterdir()) == sorted(p.name for p in ref.iterdir())
    assert (out / "manifest.json").read_bytes() == (ref / "manifest.json").read_bytes()
    for p in ref.glob("*.png"):
        np.testing.assert_array_equal(iio.imread(out / p.name), iio.imread(p))
    np.testing.assert_array_equal(
        tifffile.imread(out / "truth_height_mm.tiff"), tifffile.imread(ref / "truth_height_mm.tiff")
    )


def test_v1_gives_gain_no_meaning_and_refuses_2d_kinds(tmp_path: Path) -> None:
    """A version-1 manifest's gain_db is ignored (as before version 2, even out of range); a
    version-2 kind in version 1 is refused by naming the version it needs."""
    folder = tmp_path / "caps"
    shutil.copytree(DATA / "capture_v1", folder)
    _edit_manifest(folder, lambda m: m["frames"][0].update(gain_db=99))
    back = read_capture_folder(folder)
    assert back.gain_db == (None,) * 8
    assert back.content_hash() == _v1_reference().content_hash()
    _edit_manifest(folder, lambda m: m.update(version=2))
    _one_line_error(folder, "field 'gain_db' must be in -20..48 dB, got 99")
    _edit_manifest(folder, lambda m: m.update(version=1))
    _edit_manifest(folder, lambda m: m["frames"][7].update(kind="image", image="x.png", name="x"))
    _one_line_error(folder, "kind 'image' needs capture format version 2", '"version": 2')
    _edit_manifest(folder, lambda m: m["frames"][7].update(kind=["image"]))
    _one_line_error(folder, "unknown kind ['image']; use one of 'fringe', 'centerline', 'uniform'")


@pytest.mark.parametrize("version", [4, "2", -1, 0, True, None, 1.5, [1]])
def test_unknown_versions_are_refused_naming_the_readable_ones(tmp_path: Path, version) -> None:
    folder = tmp_path / "caps"
    shutil.copytree(DATA / "capture_v1", folder)
    _edit_manifest(folder, lambda m: m.update(version=version))
    _one_line_error(folder, f"unsupported version {version!r}", "reads versions 1, 2 and 3")


# --- pixelwise fringe sets ------------------------------------------------------------------


def test_pixelwise_sets_group_by_map_and_refuse_mixtures() -> None:
    map_a, map_b = _map(1), _map(2)
    pw_a = [PixelwiseFringeFrame(SPEC, i, map_a) for i in range(3)]
    mixed_maps = [*pw_a[:2], PixelwiseFringeFrame(SPEC, 2, map_b)]
    # unlabelled: two maps are two sets, each incomplete
    with pytest.raises(CaptureFormatError, match=r"has shifts \[0, 1\]"):
        group_fringe_sets(mixed_maps)
    with pytest.raises(CaptureFormatError, match=r"frame c\.png has a different MIGL map"):
        group_fringe_sets(mixed_maps, set_labels=["x"] * 3, names=["a.png", "b.png", "c.png"])
    with pytest.raises(
        CaptureFormatError, match=r"is a fringe frame but a\.png a pixelwise_fringe"
    ):
        group_fringe_sets(
            [*pw_a[:2], SPEC.frames()[2]], set_labels=["x"] * 3, names=["a.png", "b.png", "c.png"]
        )
    with pytest.raises(CaptureFormatError, match="give the frames of a set one gain"):
        group_fringe_sets(pw_a, set_labels=["x"] * 3, gain_db=[0.0, 0.0, 6.0])
    # a pixelwise set and a line set of one spec are two sets, not one with repeated shifts
    sets = group_fringe_sets([*pw_a, *SPEC.frames()])
    assert [(s.frame_indices, s.is_pixelwise) for s in sets] == [
        ((0, 1, 2), True),
        ((3, 4, 5), False),
    ]
    assert sets[0].migl_map_sha256 == pw_a[0].content_sha256


def test_2d_frames_need_a_projector_they_fit() -> None:
    frames = [PixelwiseFringeFrame(SPEC, i, _map(1)) for i in range(3)]
    images = np.zeros((3, *SHAPE), np.uint8)
    with pytest.raises(CaptureFormatError, match=r"frame 0 is a pixelwise_fringe frame.*projector"):
        Captures(frames, images, 8)
    with pytest.raises(CaptureFormatError, match="projector is 24x32"):
        Captures(frames, images, 8, projector=ProjectorInfo(24, 32, 8))
    with pytest.raises(CaptureFormatError, match="above the projector's maximum 127"):
        Captures(frames, images, 8, projector=ProjectorInfo(32, 24, 7))
    with pytest.raises(CaptureFormatError, match=r"gain_db must be a number in -20\.\.48"):
        Captures(frames, images, 8, projector=PROJ, gain_db=[60.0] * 3)


def _ideal_rig() -> SimulatedRig:
    camera = CameraModel(
        width=64, height=48, bit_depth=16, read_noise_dn8=0.0, full_well_e=None, blur_px=0.0
    )
    return SimulatedRig.ideal(white_plate(6.0), camera=camera)


def test_virtual_rig_pixelwise_set_decodes_like_the_line_set(tmp_path: Path) -> None:
    """On an ideal rig a constant MIGL map gives the same images as the line frames at that MIGL,
    so the set, written as a version-2 folder and read back, decodes to the same wrapped phase
    bit for bit; a non-constant map changes the amplitude, not the phase (2 pi u / p). The two
    sets stay two families (not one family with a repeated pitch)."""
    rig = _ideal_rig()
    proj = rig.projector
    spec = FringeSpec("sinusoidal", 4, 9.0, "vertical", 40 * 257, 65535)
    const = np.full((proj.height, proj.width), 50000.0)
    varying = np.tile(np.linspace(30000.0, 65535.0, proj.width), (proj.height, 1))
    frames = [
        *[PixelwiseFringeFrame(spec, i, const) for i in range(4)],
        *[FringeFrame(spec.with_migl(50000.0), i) for i in range(4)],
        *[PixelwiseFringeFrame(spec, i, varying) for i in range(4)],
    ]
    settings = CameraSettings(exposure_ms=10.0, gain_db=0.0)
    caps = Captures(
        frames,
        rig.capture(frames, settings),
        rig.camera_bit_depth,
        projector=proj,
        exposure_ms=[10.0] * 12,
        gain_db=[0.0] * 12,
    )
    back = read_capture_folder(write_capture_folder(tmp_path / "caps", caps))
    assert back.frames == frames and [s.is_pixelwise for s in back.sets] == [True, False, True]
    decoded = decode_captures(back)
    pw, line, var = (decoded.set_results[s.label] for s in back.sets)
    assert np.mean(pw.valid) > 0.95
    np.testing.assert_array_equal(pw.wrapped_phase, line.wrapped_phase)
    truth = rig.truth()
    ok = truth.valid & var.valid
    assert ok.mean() > 0.95
    err = np.angle(np.exp(1j * (var.wrapped_phase - TWO_PI * truth.u / 9.0)))[ok]
    assert np.abs(err).max() < 1e-3
    assert not np.allclose(var.modulation[ok], pw.modulation[ok], rtol=0.05)  # the map acts
    for fam in decoded.families:
        assert len({s.migl_map_sha256 for s in fam.sets}) == 1


# --- hostile side files ---------------------------------------------------------------------


@pytest.fixture
def v2_folder(tmp_path: Path) -> Path:
    return write_capture_folder(tmp_path / "caps", _v2_captures())


def _first_map(folder: Path) -> Path:
    m = json.loads((folder / "manifest.json").read_text())
    return folder / m["frames"][0]["migl_map"]


def _escape(folder: Path) -> list[str]:
    (folder.parent / "evil.tiff").write_bytes(_first_map(folder).read_bytes())
    _edit_manifest(folder, lambda m: m["frames"][0].update(migl_map="projector/../../evil.tiff"))
    return ["manifest frame 0", "leaves the capture folder"]


def _absolute(folder: Path) -> list[str]:
    _edit_manifest(folder, lambda m: m["frames"][1].update(migl_map=str(_first_map(folder))))
    return ["manifest frame 1", "leaves the capture folder"]


def _missing(folder: Path) -> list[str]:
    _first_map(folder).unlink()
    return [_first_map(folder).name, "does not exist"]


def _wrong_shape(folder: Path) -> list[str]:
    tifffile.imwrite(_first_map(folder), np.full((23, 32), 100.0, np.float32))
    return [_first_map(folder).name, "side file is 32x23 but the projector is 32x24"]


def _two_channels(folder: Path) -> list[str]:
    data = np.full((24, 32, 2), 100.0, np.float32)
    tifffile.imwrite(_first_map(folder), data, photometric="minisblack", planarconfig="contig")
    return [_first_map(folder).name, "side file is of shape (24, 32, 2) but the projector"]


def _pages(folder: Path) -> list[str]:
    data = np.full((3, 24, 32), 100.0, np.float32)
    tifffile.imwrite(_first_map(folder), data, photometric="minisblack")
    return [_first_map(folder).name, "holds 3 TIFF pages"]


def _digest(folder: Path) -> list[str]:
    data = tifffile.imread(_first_map(folder))
    data[3, 4] += 1.0
    tifffile.imwrite(_first_map(folder), data)
    return ["manifest frame 0", _first_map(folder).name, "content_sha256"]


def _float64(folder: Path) -> list[str]:
    tifffile.imwrite(_first_map(folder), tifffile.imread(_first_map(folder)).astype(np.float64))
    return [_first_map(folder).name, "holds float64 values"]


def _nan(folder: Path) -> list[str]:
    data = tifffile.imread(_first_map(folder))
    data[0, 0] = np.nan
    tifffile.imwrite(_first_map(folder), data)
    return [_first_map(folder).name, "non-finite"]


def _above_projector(folder: Path) -> list[str]:
    m = json.loads((folder / "manifest.json").read_text())
    png = folder / m["frames"][6]["image"]
    iio.imwrite(png, np.full((24, 32), 300, np.uint16))
    return [png.name, "300..300, outside the projector's 0..255"]


def _rgb_png(folder: Path) -> list[str]:
    m = json.loads((folder / "manifest.json").read_text())
    png = folder / m["frames"][6]["image"]
    iio.imwrite(png, np.zeros((24, 32, 3), np.uint8))
    return [png.name, "mode RGB, not single-channel"]


def _truncated(folder: Path) -> list[str]:
    _first_map(folder).write_bytes(_first_map(folder).read_bytes()[:30])
    return [_first_map(folder).name, "corrupt or truncated"]


def _camera_image(folder: Path) -> list[str]:
    _edit_manifest(folder, lambda m: m["frames"][0].update(migl_map=m["frames"][1]["file"]))
    return ["is the camera image of frame 1"]


def _no_projector(folder: Path) -> list[str]:
    _edit_manifest(folder, lambda m: m.pop("projector"))
    return ["frame 0", "no projector width and height"]


def _bad_digest_field(folder: Path) -> list[str]:
    _edit_manifest(folder, lambda m: m["frames"][0].update(content_sha256="abc"))
    return ["manifest frame 0", "64 lowercase hex digits"]


HOSTILE = [
    _escape,
    _absolute,
    _missing,
    _wrong_shape,
    _two_channels,
    _pages,
    _digest,
    _float64,
    _nan,
    _above_projector,
    _rgb_png,
    _truncated,
    _camera_image,
    _no_projector,
    _bad_digest_field,
]


@pytest.mark.parametrize("spoil", HOSTILE, ids=[f.__name__.strip("_") for f in HOSTILE])
def test_hostile_side_files_give_one_line(v2_folder: Path, spoil) -> None:
    needles = spoil(v2_folder)
    _one_line_error(v2_folder, *needles)


def _declare_huge(folder: Path) -> Path:
    """Rewrite the first map's header to declare 200000 x 150000 float32 (120 GB)."""
    path = _first_map(folder)
    tifffile.imwrite(path, tifffile.imread(path))  # uncompressed, one strip
    with tifffile.TiffFile(path, mode="r+b") as tif:
        tags = tif.pages.first.tags
        tags["ImageWidth"].overwrite(200000)
        tags["ImageLength"].overwrite(150000)
        tags["RowsPerStrip"].overwrite(150000)
    return path


def test_a_huge_declared_size_is_refused_from_the_header(
    v2_folder: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The header's size is checked before decoding: with the TIFF decoders refusing to decode
    the huge page, the reader still names the declared size (a reader that decodes first gets
    the guard's error, or runs out of memory)."""
    path = _declare_huge(v2_folder)
    imread, asarray = tifffile.imread, tifffile.TiffPage.asarray

    def guarded_imread(file, *args, **kwargs):
        with tifffile.TiffFile(file) as tif:
            if np.prod(tif.pages.first.shape) > 10**7:
                raise AssertionError("decoded a side file before checking its declared size")
        return imread(file, *args, **kwargs)

    def guarded_asarray(page, *args, **kwargs):
        if np.prod(page.shape) > 10**7:
            raise AssertionError("decoded a side file before checking its declared size")
        return asarray(page, *args, **kwargs)

    monkeypatch.setattr(tifffile, "imread", guarded_imread)
    monkeypatch.setattr(tifffile.TiffPage, "asarray", guarded_asarray)
    _one_line_error(v2_folder, path.name, "side file is 200000x150000 but the projector is 32x24")


def test_a_huge_projector_is_refused_before_reading_side_files(v2_folder: Path) -> None:
    _edit_manifest(v2_folder, lambda m: m["projector"].update(width=100000, height=100000))
    _one_line_error(v2_folder, "100000x100000 is 10000000000 pixels")


@pytest.mark.parametrize(
    "spoil", [_escape, _digest, _declare_huge], ids=["escape", "digest", "huge"]
)
def test_hostile_folders_write_no_output(v2_folder: Path, tmp_path: Path, spoil) -> None:
    """Through the command line: exit code 2, one line, no output folder, no staging folder."""
    spoil(v2_folder)
    out = tmp_path / "out"
    res = run_cli("phase", str(v2_folder), "-o", str(out))
    assert res.returncode == 2, res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), res.stderr
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out.")]


# --- pattern folders ------------------------------------------------------------------------


def test_pattern_folder_plays_2d_frames_and_becomes_a_capture_folder(tmp_path: Path) -> None:
    """The pattern folder holds each frame's rendered projector image (gamma pre-compensated,
    equal to render_frame), the side files, and a version-2 manifest; adding ``camera`` and
    captured images to a copy of it gives a capture folder that reads back the same frames."""
    map_a = _map(3)
    frames = [
        *[PixelwiseFringeFrame(SPEC, i, map_a) for i in range(3)],
        ImageFrame(np.eye(PROJ.height, PROJ.width) * 255, "diagonal"),
        *SPEC.frames(),
    ]
    out = tmp_path / "patterns"
    manifest = write_pattern_folder(out, frames, PROJ)
    assert manifest["version"] == 2 and manifest["format"] == "hdrfringe-patterns"
    for f, entry in zip(frames, manifest["frames"], strict=True):
        played = iio.imread(out / entry["file"])
        expect = render_frame(f, PROJ.width, PROJ.height, PROJ.gamma_precompensation, 8)
        np.testing.assert_array_equal(played, expect)
    assert len(list((out / "projector").iterdir())) == 2  # one map, one image
    assert json.loads((out / "manifest.json").read_text()) == manifest
    # a capture program: same manifest plus camera and the captured images
    capture = tmp_path / "captured"
    shutil.copytree(out, capture)
    m = dict(manifest, format="hdrfringe-captures", camera={"bit_depth": 8})
    for k, entry in enumerate(m["frames"]):
        iio.imwrite(capture / entry["file"], np.full(SHAPE, k, np.uint8))
    (capture / "manifest.json").write_text(json.dumps(m))
    back = read_capture_folder(capture)
    assert back.frames == frames and back.images[:, 0, 0].tolist() == list(range(7))
    # line frames only: version 1, no side files
    assert write_pattern_folder(tmp_path / "p1", SPEC.frames(), PROJ)["version"] == 1
    assert not (tmp_path / "p1" / "projector").exists()


# --- the documented example ---------------------------------------------------------------------


def _documented_v2_manifest() -> dict:
    text = (Path(__file__).parents[1] / "docs" / "capture_format.md").read_text()
    section = text[text.index("## Version 2") :]
    start = section.index("```json\n") + len("```json\n")
    return json.loads(section[start : section.index("```", start)])


def test_documented_example_is_valid_and_its_digests_follow_the_documented_rule(
    tmp_path: Path,
) -> None:
    """The example manifest in docs/capture_format.md passes the reader's checks, and its
    digests are SHA-256 of "<h>x<w>|" + little-endian float32 values of the data it describes,
    computed here with hashlib from the docs' definition (not with hdrfringe's digest), which
    the frames also give. Rejects a stale example and a digest convention drifting from the
    docs (e.g. big-endian, float64, no shape prefix)."""
    import hashlib

    manifest = _documented_v2_manifest()
    folder = tmp_path / "doc"
    folder.mkdir()
    (folder / "manifest.json").write_text(json.dumps(manifest))
    m = read_manifest(folder)
    assert m["version"] == 2 and len(m["frames"]) == 7
    migl = np.full((768, 1024), 255.0)
    migl[:, :512] = 180.0
    markers = np.zeros((768, 1024))
    markers[::64, :] = 255.0
    for data, entry, frame in (
        (migl, m["frames"][0], PixelwiseFringeFrame(SPEC, 0, migl)),
        (markers, m["frames"][3], ImageFrame(markers, "markers")),
    ):
        expect = hashlib.sha256(b"768x1024|" + data.astype("<f4").tobytes()).hexdigest()
        assert entry["content_sha256"] == expect == frame.content_sha256
        assert entry[frame.DATA_FIELD] == frame.default_data_file()
    # the described captures write exactly this manifest (file names, fields, version)
    frames = [
        *[PixelwiseFringeFrame(SPEC, i, migl) for i in range(3)],
        ImageFrame(markers, "markers"),
        *SPEC.frames(),
    ]
    caps = Captures(
        frames,
        np.zeros((7, 2, 2), np.uint16),
        12,
        projector=ProjectorInfo(1024, 768, 8, 2.812),
        exposure_ms=[8.0] * 3 + [16.0] * 4,
        gain_db=[0.0] * 3 + [None] + [6.0] * 3,
    )
    out = write_capture_folder(tmp_path / "caps", caps)
    assert json.loads((out / "manifest.json").read_text()) == manifest
