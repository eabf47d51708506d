"""``hdrfringe import``: synthetic image folders for every description feature and every error.

The images are rendered here from written-out pattern formulas (numpy cos/sin with the shift
angles of each case), not by hdrfringe, so a wrong shift renumbering, sign, offset or pitch in
the importer shows as a phase that disagrees with the projector coordinate the images encode.
Every refused input must give exit status 2, one ``error:`` line, and write nothing.
"""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest
import tifffile

from hdrfringe.core.decode import decode_captures
from hdrfringe.errors import CaptureFormatError, InputError
from hdrfringe.io.captures import read_capture_folder
from hdrfringe.io.import_description import compile_template, read_description
from hdrfringe.io.importer import import_captures, natural_key, to_counts
from tests.conftest import run_cli, run_cli_in_process

H, W = 24, 40
TWO_PI = 2 * np.pi


def projector_x(slope: float = 0.9, x0: float = 3.0) -> np.ndarray:
    """The projector coordinate each camera pixel sees (an ideal, tilted view)."""
    rows, cols = np.mgrid[0:H, 0:W]
    return x0 + slope * cols + 0.1 * rows


def fringe_image(
    pitch: float, shift_deg: float, *, sine: bool = False, offset_deg: float = 0.0
) -> np.ndarray:
    """8-bit camera image of ``30 + 180*(1 + P(2*pi*x/p + offset + shift))/2``."""
    t = TWO_PI * projector_x() / pitch + np.radians(offset_deg + shift_deg)
    profile = np.sin(t) if sine else np.cos(t)
    return np.rint(30 + 90 * (1 + profile)).astype(np.uint8)


def write(folder: Path, rel: str, image: np.ndarray) -> Path:
    path = folder / rel
    path.parent.mkdir(parents=True, exist_ok=True)
    iio.imwrite(path, image)
    return path


def toml(tmp_path: Path, text: str, name: str = "d.toml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def decoded_phase(folder: Path) -> dict[str, np.ndarray]:
    """Wrapped phase of every set of an imported folder, by set label."""
    dec = decode_captures(read_capture_folder(folder), min_modulation=0.0)
    return {label: r.wrapped_phase for label, r in dec.set_results.items()}


def assert_phase_is(phase: np.ndarray, pitch: float) -> None:
    """The decoded phase is 2*pi*x/p (mod 2*pi) of the projector coordinate."""
    truth = np.mod(TWO_PI * projector_x() / pitch, TWO_PI)
    err = np.mod(phase - truth + np.pi, TWO_PI) - np.pi
    assert np.abs(err).max() < 0.02, np.abs(err).max()  # 8-bit rounding


# =============================================================================================
# description features
# =============================================================================================


def test_template_orientations_periods_steps_copied_byte_for_byte(tmp_path: Path) -> None:
    cam = tmp_path / "cam"
    for o, name in (("vertical", ""), ("horizontal", "h")):
        for f in (4, 8):
            pitch = (160 if o == "vertical" else 120) / f
            for k in range(4):
                write(cam, f"sub/scan{name}_f{f:03d}_n{k:02d}.png", fringe_image(pitch, 90 * k))
    write(cam, "sub/notes.txt", np.zeros((1, 1), np.uint8))  # ignored, reported
    desc = toml(
        tmp_path,
        """
        [camera]
        bit_depth = 8
        [projector]
        width = 160
        height = 120
        [[fringe]]
        files = "**/scan{orientation}_f{periods:03d}_n{step:02d}.png"
        orientation = ["vertical", "horizontal"]
        orientation_names = { vertical = "", horizontal = "h" }
        periods = [4, 8]
        steps = 4
        imin = 30
        migl = 210
        """,
    )
    rep = import_captures(cam, desc, tmp_path / "caps")
    frames = rep.manifest["frames"]
    assert rep.manifest["version"] == 1 and len(frames) == 16 and rep.copied == 16
    assert (frames[0]["imin"], frames[0]["migl"]) == (30.0, 210.0)
    assert [f["pitch"] for f in frames[::4]] == [40.0, 20.0, 30.0, 15.0]  # width/F, height/F
    assert [f["shift"] for f in frames[:4]] == [0, 1, 2, 3]
    assert frames[4]["file"] == "sub/scan_f008_n00.png"
    for f in frames:  # copied, not re-encoded
        assert (tmp_path / "caps" / f["file"]).read_bytes() == (cam / f["file"]).read_bytes()
    assert "sub/notes.txt" in rep.ignored
    phases = decoded_phase(tmp_path / "caps")
    assert_phase_is(phases["s4_p40_v_i30_g210"], 40.0)
    assert_phase_is(phases["s4_p20_v_i30_g210"], 20.0)


def test_plain_number_field_matches_any_padding(tmp_path: Path) -> None:
    cam = tmp_path / "cam"
    for k, name in enumerate(("img_0.png", "img_01.png", "img_002.png")):
        write(cam, name, fringe_image(16, 120 * k))
    desc = toml(
        tmp_path,
        '[camera]\nbit_depth = 8\n[[fringe]]\nfiles = "img_{step}.png"\nsteps = 3\npitch = 16\n',
    )
    rep = import_captures(cam, desc, tmp_path / "caps")
    assert [f["file"] for f in rep.manifest["frames"]] == ["img_0.png", "img_01.png", "img_002.png"]


def test_regex_fallback(tmp_path: Path) -> None:
    cam = tmp_path / "cam"
    for k in range(3):
        write(cam, f"run7/phase-{k + 1}-of-3.png", fringe_image(12, 120 * k))
    desc = toml(
        tmp_path,
        r"""
        [camera]
        bit_depth = 8
        [[fringe]]
        regex = 'run\d+/phase-(?P<step>\d)-of-3\.png'
        step_numbers = [1, 2, 3]
        steps = 3
        pitch = 12
        """,
    )
    rep = import_captures(cam, desc, tmp_path / "caps")
    assert [f["shift"] for f in rep.manifest["frames"]] == [0, 1, 2]
    # no imin/migl given: the levels are left out (version 3, "levels unknown")
    assert rep.manifest["version"] == 3 and "imin" not in rep.manifest["frames"][0]
    assert_phase_is(decoded_phase(tmp_path / "caps")["s3_p12_v"], 12.0)


def test_shifts_minus120_0_120_renumbered_to_version_1(tmp_path: Path) -> None:
    """kamino410's -120/0/+120: the contract's angles in another order -> version 1 indices."""
    cam = tmp_path / "cam"
    for i, s in enumerate((-120, 0, 120)):
        write(cam, f"pat{i:02d}.png", fringe_image(20, s))
    desc = toml(
        tmp_path,
        """
        [camera]
        bit_depth = 8
        [[fringe]]
        files = ["pat00.png", "pat01.png", "pat02.png"]
        pitch = 20
        shifts_deg = [-120, 0, 120]
        imin = 0
        migl = 255
        """,
    )
    rep = import_captures(cam, desc, tmp_path / "caps")
    assert rep.manifest["version"] == 1
    assert [f["shift"] for f in rep.manifest["frames"]] == [2, 0, 1]  # -120 = 240 = index 2
    assert_phase_is(decoded_phase(tmp_path / "caps")["s3_p20_v_i0_g255"], 20.0)


def test_sine_profile_and_arbitrary_shifts_version_3(tmp_path: Path) -> None:
    """Sine, offsets and unequal shifts decode to 2*pi*x/p; the plain cosine reading does not."""
    cam = tmp_path / "cam"
    for k in range(4):  # thomriiii-style sine, 90-degree steps
        write(cam, f"sine/{k}.png", fringe_image(24, 90 * k, sine=True))
    for k, s in enumerate((0, 100, 200)):  # unequal shifts with an offset of 30 degrees
        write(cam, f"odd/{k}.png", fringe_image(18, s, offset_deg=30))
    for k, s in enumerate((0, 120, 240)):  # the opposite sign convention: cos(t - s)
        write(cam, f"neg/{k}.png", fringe_image(15, -s))
    desc = toml(
        tmp_path,
        """
        [camera]
        bit_depth = 8
        [[fringe]]
        files = "sine/{step}.png"
        steps = 4
        pitch = 24
        profile = "sine"
        [[fringe]]
        files = "odd/{step}.png"
        shifts_deg = [0, 100, 200]
        phase_offset_deg = 30
        pitch = 18
        [[fringe]]
        files = "neg/{step}.png"
        shifts_deg = [0, 120, 240]
        shift_sign = -1
        pitch = 15
        """,
    )
    rep = import_captures(cam, desc, tmp_path / "caps")
    frames = rep.manifest["frames"]
    assert rep.manifest["version"] == 3
    assert frames[0]["phase_offset_deg"] == -90 and "shift_deg" not in frames[0]
    assert [f["shift_deg"] for f in frames[4:7]] == [0, 100, 200]
    assert frames[4]["phase_offset_deg"] == 30
    assert [f["shift"] for f in frames[7:]] == [0, 2, 1]  # -120 = index 2
    phases = decoded_phase(tmp_path / "caps")
    assert_phase_is(phases["s4_p24_v_o-90"], 24.0)
    assert_phase_is(phases["s3_p18_v_o30_d0_100_200"], 18.0)
    assert_phase_is(phases["s3_p15_v"], 15.0)
    # the importer is what makes this right: read as a plain cosine the sine set is off by pi/2
    naive = np.mod(TWO_PI * projector_x() / 24 - np.pi / 2, TWO_PI)
    err = np.mod(phases["s4_p24_v_o-90"] - naive + np.pi, TWO_PI) - np.pi
    assert np.abs(err).min() > 1.5


def test_npz_and_npy_stacks_with_axes_and_selection(tmp_path: Path) -> None:
    cam = tmp_path / "cam"
    cam.mkdir()
    imgs = np.stack([fringe_image(14, 120 * k).astype(np.uint16) * 200 for k in range(3)])
    np.savez(cam / "frames.npz", frames=np.moveaxis(imgs, 0, -1), other=np.zeros(3))  # (y, x, n)
    extra = np.concatenate([imgs[:1] * 0, imgs[::-1]])  # 4 frames: a blank, then 2, 1, 0
    np.save(cam / "stack.npy", extra)
    desc = toml(
        tmp_path,
        """
        [camera]
        bit_depth = 16
        [[fringe]]
        stack = "frames.npz"
        key = "frames"
        axes = "yxn"
        steps = 3
        pitch = 14
        [[fringe]]
        stack = "stack.npy"
        stack_frames = [3, 2, 1]
        steps = 3
        pitch = 14
        orientation = "horizontal"
        [[uniform]]
        stack = "stack.npy"
        stack_frames = [0]
        level = "black"
        """,
    )
    rep = import_captures(cam, desc, tmp_path / "caps")
    assert rep.converted == 7 and rep.copied == 0
    caps = read_capture_folder(tmp_path / "caps")
    assert caps.images.dtype == np.uint16
    np.testing.assert_array_equal(caps.images[:3], imgs)
    np.testing.assert_array_equal(caps.images[3:6], imgs)
    assert not caps.images[6].any()
    assert rep.manifest["frames"][0]["file"] == "frames_frames_000.png"


def test_float_images_scaled_without_loss(tmp_path: Path) -> None:
    cam = tmp_path / "cam"
    cam.mkdir()
    counts = [fringe_image(10, 120 * k).astype(np.uint16) * 16 for k in range(3)]  # 12-bit
    for k, c in enumerate(counts):
        tifffile.imwrite(cam / f"f{k}.tiff", (c / 4095.0).astype(np.float32))
    desc = toml(
        tmp_path,
        """
        [camera]
        bit_depth = 12
        float_scale = 4095
        [[fringe]]
        files = "f{step}.tiff"
        steps = 3
        pitch = 10
        """,
    )
    rep = import_captures(cam, desc, tmp_path / "caps")
    assert rep.converted == 3
    assert [f["file"] for f in rep.manifest["frames"]] == ["f0.png", "f1.png", "f2.png"]
    np.testing.assert_array_equal(read_capture_folder(tmp_path / "caps").images, counts)


def test_to_counts_refuses_lossy_conversions() -> None:
    with pytest.raises(CaptureFormatError, match="not whole counts"):
        to_counts(np.array([[1.0, 2.5]]), 8, 1.0, "x")
    with pytest.raises(CaptureFormatError, match=r"outside 0\.\.255"):
        to_counts(np.array([[1.0, 256.0]]), 8, 1.0, "x")
    with pytest.raises(CaptureFormatError, match=r"outside 0\.\.255"):
        to_counts(np.array([[-1.0]]), 8, 1.0, "x")
    with pytest.raises(CaptureFormatError, match="float_scale"):
        to_counts(np.array([[1.0]]), 8, None, "x")
    with pytest.raises(CaptureFormatError, match="NaN"):
        to_counts(np.array([[np.nan]]), 8, 1.0, "x")
    with pytest.raises(CaptureFormatError, match=r"outside 0\.\.4095"):
        to_counts(np.array([[4096]], np.uint16), 12, None, "x")
    # float32 rounding of k/65535 is not a loss
    k = np.arange(65536, dtype=np.float64)
    back = to_counts((k / 65535).astype(np.float32)[None], 16, 65535.0, "x")
    np.testing.assert_array_equal(back[0], k)


def test_rgb_copied_and_read_by_the_luma_rule_bmp_converted(tmp_path: Path) -> None:
    cam = tmp_path / "cam"
    rgb = np.stack([fringe_image(16, 120 * k) for k in range(3)])
    colour = np.stack([rgb, rgb // 2, rgb // 3], axis=-1)  # (3, H, W, 3)
    colour[0, 0, 0] = (255, 0, 0)  # one clipped channel
    for k in range(3):
        write(cam, f"c{k}.png", colour[k])
    write(cam, "white.bmp", np.full((H, W), 250, np.uint8))
    desc = toml(
        tmp_path,
        """
        [camera]
        bit_depth = 8
        [[fringe]]
        files = "c{step}.png"
        steps = 3
        pitch = 16
        [[uniform]]
        files = "white.bmp"
        level = "white"
        """,
    )
    rep = import_captures(cam, desc, tmp_path / "caps")
    assert rep.copied == 3 and rep.converted == 1
    caps = read_capture_folder(tmp_path / "caps")
    luma = colour[1].astype(np.float32) @ np.array([0.299, 0.587, 0.114], np.float32)
    np.testing.assert_allclose(caps.images[1], luma, rtol=0, atol=1e-4)
    assert caps.images[0][0, 0] == 255  # a clipped channel stays saturated
    assert rep.manifest["frames"][3] == {"file": "white.png", "kind": "uniform", "level": 255.0}
    np.testing.assert_array_equal(caps.images[3], 250)


def test_pattern_manifest_as_description(tmp_path: Path) -> None:
    pat = tmp_path / "pat"
    res = run_cli(
        "patterns", "-o", str(pat), "--steps", "3", "--pitch", "8,16", "--width", "64",
        "--height", "48", "--gray", "128", "--no-centerline",
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    played = json.loads((pat / "manifest.json").read_text())["frames"]
    cam = tmp_path / "cam"
    for i in range(len(played)):  # cam1.png .. cam7.png: natural order, not cam1, cam10, ...
        write(cam, f"cam{i + 1}.png", np.full((H, W), 10 * i, np.uint16))
    rep = import_captures(cam, pat / "manifest.json", tmp_path / "caps", bit_depth=10)
    frames = rep.manifest["frames"]
    assert rep.manifest["camera"] == {"bit_depth": 10}
    assert [f["file"] for f in frames] == [f"cam{i + 1}.png" for i in range(len(played))]
    for got, want in zip(frames, played, strict=True):
        assert {k: v for k, v in got.items() if k != "file"} == {
            k: v for k, v in want.items() if k != "file"
        }
    assert len(read_capture_folder(tmp_path / "caps").sets) == 2
    assert natural_key("cam10.png") > natural_key("cam9.png")


def test_template_compiler() -> None:
    t = compile_template("a/{pitch:.1f}/{step}.png", "fringe", {}, "t")
    assert t.parse("a/66.7/3.png") == {"pitch": 66.7, "step": 3.0}
    assert t.parse("a/66.70/3.png") is None  # the spec asks for one decimal
    assert t.parse("b/66.7/3.png") is None
    star = compile_template("*/x_{step}.png", "fringe", {}, "t")
    assert star.parse("any/x_1.png") == {"step": 1.0}
    assert star.parse("a/b/x_1.png") is None  # * stays within one folder level


def test_cli_import_then_phase(tmp_path: Path) -> None:
    cam = tmp_path / "cam"
    for k in range(3):
        write(cam, f"s{k}.png", fringe_image(16, 120 * k))
    desc = toml(
        tmp_path,
        '[camera]\nbit_depth = 8\n[[fringe]]\nfiles = "s{step}.png"\nsteps = 3\npitch = 16\n',
    )
    res = run_cli("import", str(cam), "--description", str(desc), "-o", str(tmp_path / "caps"))
    assert res.returncode == 0, res.stderr
    assert "imported 3 frames" in res.stdout
    res = run_cli("import", str(cam), "-d", str(desc), "-o", str(tmp_path / "caps"), "--force")
    assert res.returncode == 0, res.stderr
    res = run_cli("phase", str(tmp_path / "caps"), "-o", str(tmp_path / "ph"))
    assert res.returncode == 0, res.stderr


# =============================================================================================
# errors: one line, exit 2, nothing written
# =============================================================================================


def assert_refused(
    tmp_path: Path, cam: Path, desc: Path, *needles: str, extra: tuple[str, ...] = ()
) -> None:
    out = tmp_path / "caps"
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    # in-process: the CLI's entry point, with what a process would report (conftest)
    res = run_cli_in_process("import", str(cam), "-d", str(desc), "-o", str(out), *extra)
    assert res.returncode == 2, (res.stdout, res.stderr)
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), res.stderr
    assert "Traceback" not in res.stderr
    for n in needles:
        assert n in lines[0], lines[0]
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*")) == before


@pytest.fixture
def cam3(tmp_path: Path) -> Path:
    cam = tmp_path / "cam"
    for k in range(3):
        write(cam, f"s{k}.png", fringe_image(16, 120 * k))
    return cam


GOOD = '[camera]\nbit_depth = 8\n[[fringe]]\nfiles = "s{step}.png"\nsteps = 3\npitch = 16\n'


@pytest.mark.parametrize(
    ("text", "needles"),
    [
        pytest.param(  # a template naming files that do not exist
            GOOD.replace("steps = 3", "steps = 4"),
            ("no image for frame 'vertical pitch 16 step 3'", "'s3.png'"),
            id="missing-file",
        ),
        pytest.param(
            GOOD.replace('files = "s{step}.png"', 'files = ["s0.png", "s1.png", "s9.png"]'),
            ("'s9.png' does not exist",),
            id="listed-file-missing",
        ),
        pytest.param(
            GOOD.replace('files = "s{step}.png"', 'stack = "x.npz"'),
            ("stack 'x.npz' does not exist",),
            id="stack-missing",
        ),
        pytest.param(
            GOOD.replace("steps = 3", "steps = 4\nshifts_deg = [0, 120, 240]"),
            ("steps = 4 but shifts_deg lists 3 angles",),
            id="inconsistent-shift-count",
        ),
        pytest.param(
            GOOD + "step_numbers = [0, 1]\n",
            ("step_numbers lists 2 numbers for 3 steps",),
            id="inconsistent-step-numbers",
        ),
        pytest.param(
            GOOD.replace('files = "s{step}.png"', 'files = ["s0.png", "s1.png"]'),
            ("'files' lists 2 paths for 3 frames",),
            id="inconsistent-file-count",
        ),
        pytest.param(
            GOOD.replace("pitch = 16", "perods = 4"),
            ("unknown key 'perods'", "did you mean 'periods'?"),
            id="unknown-key",
        ),
        pytest.param(
            GOOD.replace("bit_depth = 8", "bitdepth = 8"),
            ("unknown key 'bitdepth'", "did you mean 'bit_depth'?"),
            id="unknown-camera-key",
        ),
        pytest.param(
            GOOD.replace("{step}", "{stpe}"),
            ("unknown template field {stpe}", "did you mean 'step'?"),
            id="unknown-template-field",
        ),
        pytest.param(
            GOOD.replace("[[fringe]]", "[[fringes]]"),
            ("unknown key 'fringes'", "did you mean 'fringe'?"),
            id="unknown-table",
        ),
        pytest.param(
            GOOD.replace('"s{step}.png"', '"s*.png"'),
            ("has no {step} field",),
            id="template-without-step",
        ),
        pytest.param(
            GOOD.replace("pitch = 16", "periods = 4"),
            ("'periods' needs the projector width",),
            id="periods-without-projector",
        ),
        pytest.param(GOOD.replace("= 8", "= "), ("not a valid TOML",), id="bad-toml"),
        pytest.param(
            GOOD + "migl = 200\n", ("give both 'imin' and 'migl' or neither",), id="one-level"
        ),
        pytest.param(
            GOOD.replace("bit_depth = 8", "bit_depth = 6"),
            ("values reach 210, above 2^B - 1 = 63", "camera.bit_depth in the description"),
            id="values-above-bit-depth",
        ),
        pytest.param(
            GOOD + '[[uniform]]\nfiles = "s1.png"\nlevel = 255\n',
            ("s1.png is the image of two frames",),
            id="one-file-two-frames",
        ),
    ],
)
def test_bad_description_refused(
    tmp_path: Path, cam3: Path, text: str, needles: tuple[str, ...]
) -> None:
    assert_refused(tmp_path, cam3, toml(tmp_path, text), *needles)


def test_two_files_match_one_frame(tmp_path: Path, cam3: Path) -> None:
    write(cam3, "s01.png", fringe_image(16, 120))  # s1.png and s01.png are both step 1
    assert_refused(tmp_path, cam3, toml(tmp_path, GOOD), "2 files match frame", "'s01.png'")


def test_lossy_float_refused(tmp_path: Path) -> None:
    cam = tmp_path / "cam"
    cam.mkdir()
    for k in range(3):
        tifffile.imwrite(cam / f"s{k}.tiff", fringe_image(16, 120 * k).astype(np.float32) + 0.5)
    desc = toml(
        tmp_path, GOOD.replace(".png", ".tiff").replace("= 8\n", "= 8\nfloat_scale = 1\n", 1)
    )
    assert_refused(tmp_path, cam, desc, "not whole counts after scaling by 1")


def test_images_of_two_sizes_refused(tmp_path: Path, cam3: Path) -> None:
    write(cam3, "s2.png", np.zeros((H + 1, W), np.uint8))
    assert_refused(tmp_path, cam3, toml(tmp_path, GOOD), "all frames must have one size")


def test_incomplete_set_refused(tmp_path: Path, cam3: Path) -> None:
    """Two groups describing the same set: the capture reader's set check runs on the result."""
    text = GOOD.replace("steps = 3", "steps = 3\nstep_numbers = [0, 1, 2]") + (
        '[[fringe]]\nfiles = ["s0.png", "s1.png", "s2.png"]\nsteps = 3\npitch = 16\n'
    )
    assert_refused(tmp_path, cam3, toml(tmp_path, text), "image of two frames")


def test_existing_output_and_output_inside_input_refused(tmp_path: Path, cam3: Path) -> None:
    desc = toml(tmp_path, GOOD)
    (tmp_path / "caps").mkdir()
    (tmp_path / "caps" / "keep.txt").write_text("mine")
    assert_refused(tmp_path, cam3, desc, "--force")
    res = run_cli("import", str(cam3), "-d", str(desc), "-o", str(cam3 / "out"), "--force")
    assert res.returncode == 2 and "error:" in res.stderr
    assert not (cam3 / "out").exists()


def test_pattern_manifest_errors(tmp_path: Path, cam3: Path) -> None:
    pat = tmp_path / "pat"
    assert run_cli("patterns", "-o", str(pat), "--no-centerline").returncode == 0
    manifest = pat / "manifest.json"
    assert_refused(tmp_path, cam3, manifest, "give --bit-depth")
    write(cam3, "s3.png", fringe_image(16, 0))
    assert_refused(
        tmp_path,
        cam3,
        manifest,
        "3 frames were played",
        "holds 4 images",
        extra=("--bit-depth", "8"),
    )
    desc = toml(tmp_path, GOOD)
    assert_refused(
        tmp_path, cam3, desc, "--bit-depth is for pattern manifests", extra=("--bit-depth", "8")
    )


def test_description_api_errors(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="does not exist"):
        read_description(tmp_path / "nope.toml")
    with pytest.raises(InputError, match="no camera table"):
        read_description(toml(tmp_path, '[[uniform]]\nfiles = "a.png"\nlevel = 1\n'))
    with pytest.raises(InputError, match="exactly one of 'files', 'regex' and 'stack'"):
        read_description(toml(tmp_path, "[camera]\nbit_depth = 8\n[[uniform]]\nlevel = 1\n"))
    with pytest.raises(InputError, match="sine' is for sinusoidal"):
        read_description(
            toml(
                tmp_path,
                '[camera]\nbit_depth = 8\n[[fringe]]\nfiles = "{step}.png"\nsteps = 3\n'
                'pitch = 8\npattern = "triangular"\nprofile = "sine"\n',
            )
        )


# =============================================================================================
# Gray code
# =============================================================================================


def gray_bit_image(bit: int, stripe: float, *, inverse: bool = False) -> np.ndarray:
    """Camera image of bit ``bit`` of the binary-reflected Gray code of the stripe index."""
    m = np.floor(projector_x(slope=2.0) / stripe).astype(np.int64)
    lit = ((m ^ (m >> 1)) >> bit) & 1 == 1
    return np.where(lit != inverse, 220, 20).astype(np.uint8)


def test_graycode_groups_bit_template_and_opencv_pairs(tmp_path: Path) -> None:
    from hdrfringe.core.frames import GrayCodeFrame, opencv_graycode_frames

    cam = tmp_path / "cam"
    for b in range(3):  # file names carry the bit's significance
        write(cam, f"v/gc{b}.png", gray_bit_image(b, 8.0))
    n = 0
    for count in (3, 2):  # OpenCV's flat numbering: 3 vertical then 2 horizontal bits, pairs
        for b in range(count - 1, -1, -1):
            for inv in (False, True):
                write(cam, f"cv/pat{n:02d}.png", gray_bit_image(b, 8.0, inverse=inv))
                n += 1
    bits = """
        [camera]
        bit_depth = 8
        [[graycode]]
        files = "v/gc{bit}.png"
        bits = 3
        stripe = 8
        """
    cv = """
        [camera]
        bit_depth = 8
        [[graycode]]
        files = "cv/pat{index:02d}.png"
        bits = 3
        stripe = 8
        inverse = true
        convention = "opencv"
        [[graycode]]
        files = "cv/pat{index:02d}.png"
        first_index = 6
        orientation = "horizontal"
        bits = 2
        stripe = 8
        inverse = true
        convention = "opencv"
        """
    toml(tmp_path, bits, "bits.toml")
    toml(tmp_path, cv, "cv.toml")
    # both at once are two vertical codes: the capture reader's check refuses that
    both = toml(tmp_path, cv + bits.replace("[camera]\n        bit_depth = 8\n", ""), "both.toml")
    with pytest.raises(CaptureFormatError, match="has another code"):
        import_captures(cam, both, tmp_path / "caps")
    assert not (tmp_path / "caps").exists()

    rep = import_captures(cam, tmp_path / "bits.toml", tmp_path / "caps_bits")
    assert rep.manifest["version"] == 3
    frames = read_capture_folder(tmp_path / "caps_bits").frames
    assert frames == [GrayCodeFrame("vertical", b, 3, 8.0) for b in (2, 1, 0)]  # MSB first
    assert [f["file"] for f in rep.manifest["frames"]] == ["v/gc2.png", "v/gc1.png", "v/gc0.png"]

    rep = import_captures(cam, tmp_path / "cv.toml", tmp_path / "caps_cv")
    caps = read_capture_folder(tmp_path / "caps_cv")
    assert caps.frames == opencv_graycode_frames(64, 32, 8.0)  # OpenCV's 3 + 2 bits, in order
    assert [f["file"] for f in rep.manifest["frames"]] == [f"cv/pat{i:02d}.png" for i in range(10)]
    assert len(caps.graycode_sets()) == 2


def test_graycode_missing_bit_refused(tmp_path: Path) -> None:
    cam = tmp_path / "cam"
    for b in (0, 2):  # bit 1 missing
        write(cam, f"gc{b}.png", gray_bit_image(b, 8.0))
    desc = toml(
        tmp_path,
        '[camera]\nbit_depth = 8\n[[graycode]]\nfiles = "gc{bit}.png"\nbits = 3\nstripe = 8\n',
    )
    assert_refused(tmp_path, cam, desc, "no image for frame 'graycode vertical bit 1'", "'gc1.png'")


def test_graycode_pairs_need_index(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="cannot tell a bit's pattern from its inverse"):
        read_description(
            toml(
                tmp_path,
                '[camera]\nbit_depth = 8\n[[graycode]]\nfiles = "g{bit}.png"\nbits = 2\n'
                "stripe = 4\ninverse = true\n",
            )
        )


def test_pattern_manifest_with_side_files(tmp_path: Path) -> None:
    """A version-2 pattern folder: its MIGL map is copied beside the camera images."""
    from hdrfringe.core.captures import ProjectorInfo
    from hdrfringe.core.frames import PixelwiseFringeFrame
    from hdrfringe.core.patterns import FringeSpec
    from hdrfringe.io.pattern_folder import write_pattern_folder

    spec = FringeSpec(steps=3, pitch_px=8.0)
    migl = np.full((12, 16), 200.0)
    frames = [PixelwiseFringeFrame(spec, i, migl) for i in range(3)]
    played = write_pattern_folder(tmp_path / "pat", frames, ProjectorInfo(16, 12, 8))
    cam = tmp_path / "cam"
    for i in range(3):
        write(cam, f"c{i}.png", fringe_image(8, 120 * i))
    rep = import_captures(cam, tmp_path / "pat" / "manifest.json", tmp_path / "caps", bit_depth=8)
    assert rep.manifest["version"] == 2
    side = played["frames"][0]["migl_map"]
    assert (tmp_path / "caps" / side).read_bytes() == (tmp_path / "pat" / side).read_bytes()
    caps = read_capture_folder(tmp_path / "caps")
    assert caps.frames == frames


def test_npz_header_bomb_refused_before_inflating(tmp_path: Path) -> None:
    """An .npz member whose header declares 2^33 pixels is refused from the header alone."""
    import io
    import zipfile

    cam = tmp_path / "cam"
    cam.mkdir()
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        header, {"descr": "|u1", "fortran_order": False, "shape": (2, 1 << 16, 1 << 16)}
    )
    with zipfile.ZipFile(cam / "bomb.npz", "w") as zf:
        zf.writestr("frames.npy", header.getvalue())  # no data at all
    desc = toml(
        tmp_path,
        '[camera]\nbit_depth = 8\n[[uniform]]\nstack = "bomb.npz"\nkey = "frames"\n'
        "stack_frames = [0]\nlevel = 0\n",
    )
    assert_refused(tmp_path, cam, desc, "more than the 2147483648 pixels")


def test_pattern_manifest_side_file_outside_refused(tmp_path: Path, cam3: Path) -> None:
    pat = tmp_path / "pat"
    pat.mkdir()
    entry = {"file": "000_a.png", "kind": "image", "name": "a", "image": "../outside.png"}
    manifest = {"format": "hdrfringe-patterns", "version": 2, "frames": [entry] * 3}
    (pat / "manifest.json").write_text(json.dumps(manifest))
    assert_refused(
        tmp_path,
        cam3,
        pat / "manifest.json",
        "outside the pattern folder",
        extra=("--bit-depth", "8"),
    )
