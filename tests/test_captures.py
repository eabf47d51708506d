"""The in-memory Captures (core) and its capture-folder reader and writer (io)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.core.captures import Captures, ProjectorInfo, group_fringe_sets
from hdrfringe.core.frames import CenterlineFrame, UniformFrame
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import CaptureFormatError, InputError
from hdrfringe.io.captures import read_capture_folder, read_manifest, write_capture_folder

SPEC = FringeSpec("sinusoidal", 3, 8.0)
SHAPE = (4, 6)


def _images(n: int, dtype: type = np.uint8) -> np.ndarray:
    rng = np.random.default_rng(0)
    return rng.integers(0, 200, size=(n, *SHAPE)).astype(dtype)


def _rich() -> Captures:
    """Two labelled exposures of one set, a centerline with its exposure, a map, camera info."""
    frames = [*SPEC.frames(), *SPEC.frames(), CenterlineFrame(20.0)]
    return Captures(
        frames,
        _images(7, np.uint16),
        12,
        projector=ProjectorInfo(800, 600, 8, 2.2),
        camera={"focal_px": 1000.0, "standoff_mm": 500.0},
        scene={"depth_mm": 4.0, "name": "plate"},
        exposure_ms=[5.0] * 3 + [20.0] * 3 + [7.5],
        set_labels=["short"] * 3 + ["long"] * 3 + [None],
        gamma_precompensation=[None] * 3 + [1.5] * 3 + [None],
        maps={"truth_height_mm": np.full(SHAPE, 4.0, np.float32)},
        name="rich",
    )


# --- validation on construction ----------------------------------------------------------------


@pytest.mark.parametrize(
    ("images", "bits", "match"),
    [
        (np.zeros((2, *SHAPE), np.uint8), 8, "3 frames but images of shape"),
        (np.zeros(SHAPE, np.uint8), 8, "3 frames but images of shape"),
        (np.full((3, *SHAPE), 64, np.uint8), 6, r"values reach 64, above 2\^B - 1 = 63"),
        (np.full((3, *SHAPE), -1, np.int16), 8, "go down to -1"),
        (np.full((3, *SHAPE), np.nan, np.float32), 8, "values reach nan"),
    ],
)
def test_images_must_match_frames_and_bit_depth(images, bits, match) -> None:
    with pytest.raises(CaptureFormatError, match=match):
        Captures(SPEC.frames(), images, bits)


def test_full_scale_is_accepted_and_bit_depth_checked() -> None:
    Captures(SPEC.frames(), np.full((3, *SHAPE), 4095, np.uint16), 12)  # 2^B - 1 is valid
    with pytest.raises(InputError, match=r"camera bit depth must be an integer 1\.\.16"):
        Captures(SPEC.frames(), np.zeros((3, *SHAPE), np.uint8), 17)


def test_per_frame_fields_and_maps_are_checked() -> None:
    frames, images = SPEC.frames(), _images(3)
    with pytest.raises(InputError, match="exposure_ms has 2 entries for 3 frames"):
        Captures(frames, images, 8, exposure_ms=[1.0, 2.0])
    with pytest.raises(CaptureFormatError, match="frame 1: exposure_ms must be a positive"):
        Captures(frames, images, 8, exposure_ms=[1.0, 0.0, 1.0])
    with pytest.raises(CaptureFormatError, match="frame 2 set label must be a string"):
        Captures(frames, images, 8, set_labels=[None, None, 3])
    with pytest.raises(CaptureFormatError, match=r"map 'truth_height_mm' is 5x4 but the images"):
        Captures(frames, images, 8, maps={"truth_height_mm": np.zeros((4, 5))})
    with pytest.raises(InputError, match="camera holds 'bit_depth'"):
        Captures(frames, images, 8, camera={"bit_depth": 8})
    with pytest.raises(InputError, match="frame 0 is a str"):
        Captures(["frame"], images[:1], 8)  # type: ignore[list-item]


def test_sets_are_grouped_and_incomplete_sets_refused() -> None:
    caps = _rich()
    assert [(s.label, s.frame_indices, s.exposure_ms) for s in caps.sets] == [
        ("short", (0, 1, 2), 5.0),
        ("long", (3, 4, 5), 20.0),
    ]
    assert caps.sets[1].gamma_precompensation == 1.5
    # without labels, the exposure and gamma split the sets and name them
    unlabelled = dataclasses.replace(caps, set_labels=())
    assert [s.label for s in unlabelled.sets] == [
        "s3_p8_v_i40_g255_e5",
        "s3_p8_v_i40_g255_e20_gp1.5",
    ]
    with pytest.raises(CaptureFormatError, match=r"has shifts \[0, 2\]"):
        Captures([SPEC.frames()[0], SPEC.frames()[2]], _images(2), 8)
    with pytest.raises(CaptureFormatError, match=r"frame b\.png has a different pattern"):
        group_fringe_sets(
            [*SPEC.frames()[:2], FringeSpec(pitch_px=9.0).frames()[2]],
            set_labels=["a"] * 3,
            names=["a.png", "c.png", "b.png"],
        )


def test_views() -> None:
    caps = _rich()
    assert caps.image_shape == SHAPE
    np.testing.assert_array_equal(caps.set_images(caps.sets[1]), caps.images[3:6])
    assert [f.position for f, _ in caps.centerlines()] == [20.0] and caps.uniforms() == []
    assert caps.map("truth_height_mm") is caps.maps["truth_height_mm"] and caps.map("x") is None
    assert repr(caps) == "Captures('rich': 7 frames of 6x4 at 12 bits, 2 fringe sets)"


# --- manifest, hash, folder round trip ---------------------------------------------------------


def test_manifest_round_trip_in_memory() -> None:
    caps = _rich()
    m = caps.to_manifest(extra={"simulator": {"seed": 3}})
    assert m["camera"] == {"bit_depth": 12, "focal_px": 1000.0, "standoff_mm": 500.0}
    assert m["simulator"] == {"seed": 3} and m["maps"] == {
        "truth_height_mm": "truth_height_mm.tiff"
    }
    assert m["frames"][3]["set"] == "long" and m["frames"][3]["gamma_precompensation"] == 1.5
    assert m["frames"][6]["exposure_ms"] == 7.5 and "set" not in m["frames"][6]
    back = Captures.from_manifest(m, caps.images, caps.maps, name="back")
    assert back.content_hash() == caps.content_hash()
    with pytest.raises(InputError, match="extra manifest field 'frames'"):
        caps.to_manifest(extra={"frames": []})


def test_content_hash_follows_the_content_only() -> None:
    caps = _rich()
    same = dataclasses.replace(caps, name="elsewhere", images=caps.images.copy())
    assert same.content_hash() == caps.content_hash()
    images = caps.images.copy()
    images[6, 0, 0] += 1
    maps = {"truth_height_mm": caps.maps["truth_height_mm"] + 1}
    for changed in (
        dataclasses.replace(caps, images=images),
        dataclasses.replace(caps, maps=maps),
        dataclasses.replace(caps, scene={"depth_mm": 5.0}),
        dataclasses.replace(caps, images=caps.images.astype(np.int32)),
    ):
        assert changed.content_hash() != caps.content_hash()


def test_folder_round_trip_keeps_everything(tmp_path: Path) -> None:
    caps = _rich()
    out = write_capture_folder(tmp_path / "caps", caps, extra={"lab": "B2"})
    back = read_capture_folder(out)
    assert back.name == str(out)
    np.testing.assert_array_equal(back.images, caps.images)
    for attr in ("camera_bit_depth", "projector", "camera", "scene", "exposure_ms"):
        assert getattr(back, attr) == getattr(caps, attr), attr
    assert back.set_labels == caps.set_labels
    assert back.gamma_precompensation == caps.gamma_precompensation
    assert back.frames == caps.frames and back.sets == caps.sets
    np.testing.assert_array_equal(back.map("truth_height_mm"), caps.map("truth_height_mm"))
    assert back.content_hash() == caps.content_hash()  # the folder's files hold the same
    assert read_manifest(out)["lab"] == "B2"


def test_reader_names_bad_maps(tmp_path: Path) -> None:
    frames = [UniformFrame(10), UniformFrame(20)]
    caps = Captures(frames, _images(2), 8, maps={"truth_height_mm": np.zeros(SHAPE)})
    folder = write_capture_folder(tmp_path / "caps", caps)
    map_file = folder / "truth_height_mm.tiff"
    map_file.write_bytes(map_file.read_bytes()[:40])
    with pytest.raises(CaptureFormatError, match=r"truth_height_mm\.tiff: cannot read map"):
        read_capture_folder(folder)
    import tifffile

    tifffile.imwrite(map_file, np.zeros((3, 6), np.float32))
    with pytest.raises(CaptureFormatError, match=r"height_mm\.tiff: map is 6x3 but the"):
        read_capture_folder(folder)
    map_file.unlink()
    with pytest.raises(CaptureFormatError, match="which is not a TIFF file in the folder"):
        read_capture_folder(folder)


def test_exposure_of_any_frame_is_read_and_checked(tmp_path: Path) -> None:
    caps = Captures([UniformFrame(10)], _images(1), 8, exposure_ms=[3.0])
    folder = write_capture_folder(tmp_path / "caps", caps)
    assert read_capture_folder(folder).exposure_ms == (3.0,)
    m = json.loads((folder / "manifest.json").read_text())
    m["frames"][0]["exposure_ms"] = -1
    (folder / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(CaptureFormatError, match="field 'exposure_ms' must be positive"):
        read_capture_folder(folder)


def test_version_2_manifest_round_trip_in_memory() -> None:
    """Gains and a pixelwise set go through to_manifest/from_manifest with a loader callback
    (no file): version 2, the map looked up by the entry's side-file path; without a loader the
    2-D frame is refused naming load_array; a version-1 manifest's gain_db is ignored."""
    from hdrfringe.core.frames import PixelwiseFringeFrame

    proj = ProjectorInfo(8, 6, 8)
    migl = np.linspace(60, 250, 48).reshape(6, 8)
    frames = [*(PixelwiseFringeFrame(SPEC, i, migl) for i in range(3)), UniformFrame(9)]
    caps = Captures(frames, _images(4), 8, projector=proj, gain_db=[None] * 3 + [12.0])
    m = caps.to_manifest()
    assert m["version"] == 2 and m["frames"][3]["gain_db"] == 12.0
    store = {m["frames"][0]["migl_map"]: migl.astype(np.float32)}
    back = Captures.from_manifest(m, caps.images, load_array=store.__getitem__)
    assert back.content_hash() == caps.content_hash() and back.gain_db == caps.gain_db
    assert back.sets[0].migl_map_sha256 == frames[0].content_sha256
    with pytest.raises(CaptureFormatError, match=r"manifest frame 0 \(0000\.png\).*load_array"):
        Captures.from_manifest(m, caps.images)
    plain = Captures([UniformFrame(9)], _images(1), 8).to_manifest()
    plain["frames"][0]["gain_db"] = 6.0
    assert Captures.from_manifest(plain, _images(1)).gain_db == (None,)


# --- every problem of a folder at once (issue 12 point 8) ----------------------------------------


def _hand_written(tmp_path: Path) -> Path:
    """A folder of two 3-step sets whose hand-written manifest has five unrelated mistakes."""
    caps = Captures([*SPEC.frames(), *FringeSpec("sinusoidal", 3, 24.0).frames()], _images(6), 8)
    folder = write_capture_folder(tmp_path / "caps", caps)
    m = json.loads((folder / "manifest.json").read_text())
    m["camera"]["focal_px"] = -3  # 1: camera
    del m["frames"][0]["pitch"]  # 2: frame 0
    m["frames"][2]["orientation"] = "diagonal"  # 3: frame 2
    m["frames"][4]["file"] = m["frames"][3]["file"]  # 4: a file named twice
    m["frames"][5]["file"] = "missing.png"  # 5: a file that does not exist
    (folder / "manifest.json").write_text(json.dumps(m))
    return folder


def test_a_manifest_check_reports_every_problem_at_once(tmp_path: Path) -> None:
    folder = _hand_written(tmp_path)
    with pytest.raises(CaptureFormatError) as info:
        read_capture_folder(folder)
    err = info.value
    assert len(err.problems) == 5, err.problems
    expected = [
        "focal_px",
        "missing field 'pitch'",
        "unknown orientation 'diagonal'",
        "both name",
        "missing.png: image file named in the manifest does not exist",
    ]
    for problem, needle in zip(err.problems, expected, strict=True):
        assert needle in problem and "\n" not in problem, (needle, problem)
    msg = str(err)
    assert "\n" not in msg and msg.startswith(err.problems[0]) and "(and 4 more: " in msg
    assert all(needle in msg for needle in expected)
    # read_manifest (fields only) lists the three field problems
    with pytest.raises(CaptureFormatError) as fields:
        read_manifest(folder)
    assert len(fields.value.problems) == 3
    # the same one line from the command line, exit status 2, no output
    from tests.conftest import run_cli

    res = run_cli("phase", str(folder), "-o", str(tmp_path / "out"))
    assert res.returncode == 2 and not (tmp_path / "out").exists()
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "(and 4 more: " in lines[0], res.stderr


def test_one_mistake_repeated_stays_one_short_line() -> None:
    problems = [f"m.json frame {i} (f{i}.png): missing field 'pitch'; add it" for i in range(200)]
    err = CaptureFormatError.from_problems(problems)
    assert err.problems == tuple(problems)
    assert str(err) == (
        f"{problems[0]} (and 199 more: m.json frame 1 (f1.png), m.json frame 2 (f2.png), "
        "m.json frame 3 (f3.png) and 196 more: missing field 'pitch')"
    )
    one = CaptureFormatError.from_problems(problems[:1])
    assert str(one) == problems[0] and one.problems == (problems[0],)


def test_every_incomplete_set_is_reported() -> None:
    frames = [*SPEC.frames()[:2], *FringeSpec("sinusoidal", 4, 9.0).frames()[1:]]
    with pytest.raises(CaptureFormatError) as info:
        group_fringe_sets(frames)
    assert len(info.value.problems) == 2
    assert "s3_p8" in info.value.problems[0] and "s4_p9" in info.value.problems[1]


# --- imin/migl optional on fringe frames (version 3, issue 12 point 8) -------------------------


def _without_levels(tmp_path: Path, version: int = 3, drop=("imin", "migl"), bits: int | None = 10):
    caps = Captures(SPEC.frames(), _images(3), 8)
    folder = write_capture_folder(tmp_path / f"v{version}{''.join(drop)}", caps)
    m = json.loads((folder / "manifest.json").read_text())
    m["version"] = version
    if bits is not None:
        m["projector"] = {"bit_depth": bits}
    for f in m["frames"]:
        for key in drop:
            del f[key]
    (folder / "manifest.json").write_text(json.dumps(m))
    return folder


def test_version_3_fringes_may_leave_out_both_gray_levels(tmp_path: Path) -> None:
    from hdrfringe.core.phase import decode_set

    caps = read_capture_folder(_without_levels(tmp_path))
    spec = caps.sets[0].spec
    assert not spec.gray_levels_given and (spec.imin, spec.migl) == (0.0, 1023.0)  # 2^Bp - 1
    assert caps.sets[0].label == "s3_p8_v"
    # decoding does not use the levels: the same phase as the set with its levels
    given = decode_set(caps.set_images(caps.sets[0]), SPEC, 8).wrapped_phase
    assert np.array_equal(decode_set(caps.set_images(caps.sets[0]), spec, 8).wrapped_phase, given)
    # without a projector bit depth, migl is 255; written back, the levels stay left out (v3)
    assert read_capture_folder(_without_levels(tmp_path / "b", bits=None)).sets[0].spec.migl == 255
    out = write_capture_folder(tmp_path / "back", caps)
    m = json.loads((out / "manifest.json").read_text())
    assert m["version"] == 3 and all("imin" not in f and "migl" not in f for f in m["frames"])
    assert read_capture_folder(out).sets[0].spec == spec


@pytest.mark.parametrize(
    ("version", "drop", "needle"),
    [
        (1, ("imin", "migl"), "missing field 'imin'"),
        (2, ("imin", "migl"), "missing field 'imin'"),
        (3, ("migl",), "gives 'imin' without 'migl'; give both gray levels or neither"),
    ],
)
def test_gray_levels_are_required_before_version_3_and_both_or_neither(
    tmp_path: Path, version, drop, needle
) -> None:
    with pytest.raises(CaptureFormatError, match=needle):
        read_capture_folder(_without_levels(tmp_path, version, drop))


def test_features_that_need_the_gray_levels_refuse_sets_without_them(tmp_path: Path) -> None:
    from hdrfringe.core.gamma.fringes import fit_gamma_fringes
    from hdrfringe.rig.replay import ReplayRig

    caps = read_capture_folder(_without_levels(tmp_path))
    with pytest.raises(CaptureFormatError, match=r"gives no imin/migl.*add imin and migl"):
        ReplayRig(caps)
    fs = caps.sets[0]
    with pytest.raises(InputError, match=r"gives no imin/migl.*add imin and migl"):
        fit_gamma_fringes([(fs.spec, 1.0, caps.set_images(fs))], camera_bit_depth=8)
    ReplayRig(Captures(SPEC.frames(), _images(3), 8))  # with the levels: accepted
