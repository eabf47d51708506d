"""Gray code: patterns, decoding, absolute phase with edge errors, frames, manifests, real data."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.core.captures import Captures, ProjectorInfo, group_graycode_sets
from hdrfringe.core.frames import (
    GrayCodeFrame,
    UniformFrame,
    frame_from_manifest,
    opencv_graycode_frames,
)
from hdrfringe.core.graycode import (
    absolute_phase_graycode,
    binary_to_gray,
    bits_needed,
    code_bit,
    decode_graycode,
    gray_to_binary,
    graycode_patterns,
    stripe_centre,
)
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import CaptureFormatError, InputError
from hdrfringe.io.captures import read_capture_folder, write_capture_folder
from hdrfringe.rig.scenes import plate
from hdrfringe.rig.simulated import SimulatedRig

TWO_PI = 2 * np.pi


# --- code words ------------------------------------------------------------------------------
def test_gray_code_words_differ_in_one_bit_and_round_trip() -> None:
    n = np.arange(4096)
    g = binary_to_gray(n)
    # reference from the definition (bit i of the Gray word = bit i XOR bit i+1 of n)
    ref = np.array([sum((((v >> i) ^ (v >> (i + 1))) & 1) << i for i in range(13)) for v in n])
    assert np.array_equal(g, ref)
    assert np.array_equal(gray_to_binary(g), n)
    flips = np.array([bin(int(v)).count("1") for v in g[1:] ^ g[:-1]])
    assert np.all(flips == 1)
    with pytest.raises(InputError):
        binary_to_gray([-1])
    with pytest.raises(InputError):
        gray_to_binary([0.5])


def test_patterns_follow_the_cells_and_bits_needed() -> None:
    pats = graycode_patterns(1920, 100.0)
    assert pats.shape == (5, 1920)
    cell = np.arange(1920) // 100
    word = sum(pats[b].astype(int) << b for b in range(5))
    assert np.array_equal(gray_to_binary(word), cell)
    binary = graycode_patterns(64, 4.0, code="binary")
    assert np.array_equal(sum(binary[b].astype(int) << b for b in range(4)), np.arange(64) // 4)
    assert (
        bits_needed(1080, 100) == 4 and bits_needed(1140, 114) == 4 and bits_needed(912, 114) == 3
    )
    with pytest.raises(InputError):
        code_bit([0], 0, 1.0, "hamming")
    with pytest.raises(InputError):
        bits_needed(100, 0.0)


def test_opencv_sequence_matches_opencv_generate() -> None:
    """OpenCV's generate(): MSB first, pattern lit where the Gray bit is 1, then its inverse;
    columns then rows. Reference: the cell's Gray word written out by hand for a 5x3 grid."""
    frames = opencv_graycode_frames(5, 3, 1.0)
    assert [(f.orientation, f.bit, f.inverse) for f in frames] == [
        ("vertical", 2, False),
        ("vertical", 2, True),
        ("vertical", 1, False),
        ("vertical", 1, True),
        ("vertical", 0, False),
        ("vertical", 0, True),
        ("horizontal", 1, False),
        ("horizontal", 1, True),
        ("horizontal", 0, False),
        ("horizontal", 0, True),
    ]
    cols = np.stack([f.render(5, 3)[0] for f in frames[0:6:2]])
    # Gray words of columns 0..4: 000 001 011 010 110, MSB first
    assert cols.tolist() == [[0, 0, 0, 0, 255], [0, 0, 255, 255, 255], [0, 255, 255, 0, 0]]
    assert np.array_equal(frames[1].render(5, 3), 255 - frames[0].render(5, 3))
    rows = np.stack([f.render(5, 3)[:, 0] for f in frames[6::2]])
    assert rows.tolist() == [[0, 0, 255], [0, 255, 255]]


# --- decoding --------------------------------------------------------------------------------
def _scene_images(x: np.ndarray, stripe: float, bits: int, code: str = "gray") -> np.ndarray:
    return np.stack([code_bit(x, b, stripe, code) for b in range(bits)]).astype(float)


def test_decode_with_inverses_and_with_a_threshold() -> None:
    rng = np.random.default_rng(1)
    x = np.tile(np.arange(640.0), (4, 1))
    albedo = rng.uniform(0.3, 1.0, x.shape)
    lit = _scene_images(x, 10.0, 6)
    pattern = 20 + 200 * albedo * lit + rng.normal(0, 1, lit.shape)
    inverse = 20 + 200 * albedo * (1 - lit) + rng.normal(0, 1, lit.shape)
    d = decode_graycode(pattern, inverses=inverse)
    truth = np.floor((x + 0.5) / 10.0)
    assert d.valid.all() and np.array_equal(d.index, truth)
    white, black = 20 + 200 * albedo, np.full(x.shape, 20.0)
    t = decode_graycode(pattern, threshold=(white + black) / 2, contrast=white - black)
    assert np.array_equal(t.index, truth)
    # binary code read as Gray is wrong: the code argument matters
    b = _scene_images(x, 10.0, 6, "binary") * 200
    assert np.array_equal(
        decode_graycode(b, threshold=np.full(x.shape, 100.0), code="binary").index, truth
    )
    assert not np.array_equal(decode_graycode(b, threshold=np.full(x.shape, 100.0)).index, truth)


def test_decode_validity_contrast_and_saturation() -> None:
    pattern = np.array([[[100.0, 255.0, 103.0, 255.0]]])
    inverse = np.array([[[10.0, 255.0, 100.0, 40.0]]])
    d = decode_graycode(pattern, inverses=inverse, min_contrast=5.0, full_scale=255)
    # 2nd: both saturated; 3rd: contrast 3 < 5; 4th: only one side saturated is fine
    assert d.valid.tolist() == [[True, False, False, True]]
    assert np.isnan(d.index[0, 1]) and d.reliability[0, 2] == 3.0
    shadow = decode_graycode(
        pattern, threshold=np.full((1, 4), 50.0), contrast=np.full((1, 4), 8.0)
    )
    assert not shadow.valid.any()
    with pytest.raises(InputError):
        decode_graycode(pattern)
    with pytest.raises(InputError):
        decode_graycode(pattern, inverses=inverse[:, :, :2])


# --- absolute phase --------------------------------------------------------------------------
def _edge_case(stripe: float, pitch: float, shift_px: float, noise: float, seed: int = 0):
    """A plane seen with 1.3 camera px per projector px: truth x, wrapped phase with noise, and
    a Gray code whose edges are blurred and offset by ``shift_px`` projector px (defocus and a
    threshold bias), so pixels near every stripe edge decode to the neighbouring stripe."""
    rng = np.random.default_rng(seed)
    h, w = 40, 1200
    x = np.tile(np.arange(w) / 1.3 + 3.0, (h, 1)) + 0.02 * np.arange(h)[:, None]
    phi = np.mod(TWO_PI * x / pitch + rng.normal(0, noise, x.shape), TWO_PI)
    index = np.floor((x + shift_px + 0.5) / stripe)
    return x, phi, index


@pytest.mark.parametrize("shift_px", [-2.0, 1.5])
def test_phase_guided_order_with_cleanup_fixes_edge_errors(shift_px: float) -> None:
    x, phi, index = _edge_case(100.0, 100.0, shift_px, 0.05)
    truth_k = np.round((TWO_PI * x / 100.0 - phi) / TWO_PI)
    fixed = absolute_phase_graycode(phi, index, stripe_px=100.0, pitch_px=100.0)
    assert np.array_equal(fixed.order, truth_k)
    assert fixed.corrected > 0
    # the variant without the cleanup keeps bands of wrong orders along the stripe edges
    raw = absolute_phase_graycode(phi, index, stripe_px=100.0, pitch_px=100.0, cleanup=False)
    wrong = raw.order != truth_k
    assert wrong.mean() > 0.005 and np.abs(raw.order - truth_k)[wrong].max() == 1
    # the naive rule "order = stripe index" (stripe = pitch, aligned) fails at every edge
    # band and wherever phase noise crosses the wrap
    assert (index != truth_k).mean() > 0.005


def test_complementary_code_needs_no_cleanup() -> None:
    """One bit finer than the pitch (stripe p/2): the order is right without cleanup."""
    x, phi, index = _edge_case(50.0, 100.0, 1.5, 0.05)
    truth_k = np.round((TWO_PI * x / 100.0 - phi) / TWO_PI)
    res = absolute_phase_graycode(phi, index, stripe_px=50.0, pitch_px=100.0, cleanup=False)
    assert np.array_equal(res.order, truth_k) and res.method.startswith("complementary")
    assert np.allclose(res.phase, phi + TWO_PI * truth_k)


def test_cleanup_keeps_real_depth_steps_and_nan() -> None:
    """A true step of 3.4 periods (an object edge) is not 'corrected'; NaN stays NaN."""
    x = np.tile(np.arange(600.0), (30, 1))
    x[:, 300:] += 340.0
    phi = np.mod(TWO_PI * x / 100.0, TWO_PI)
    index = np.floor((x + 0.5) / 100.0)
    index[5, 5] = np.nan
    res = absolute_phase_graycode(phi, index, stripe_px=100.0, pitch_px=100.0)
    ok = np.isfinite(index)
    assert np.allclose(res.phase[ok], (TWO_PI * x / 100.0)[ok]) and np.isnan(res.phase[5, 5])
    with pytest.raises(InputError, match="wider than the fringe pitch"):
        absolute_phase_graycode(phi, index, stripe_px=200.0, pitch_px=100.0)
    with pytest.raises(InputError, match="window"):
        absolute_phase_graycode(phi, index, stripe_px=100.0, pitch_px=100.0, window=4)


# --- frames, captures, manifests --------------------------------------------------------------
def test_frame_fields_and_manifest_round_trip() -> None:
    f = GrayCodeFrame("horizontal", 2, 4, 114.0, inverse=True, code="binary", convention="x")
    entry = f.manifest_entry("a.png")
    assert entry == {
        "file": "a.png",
        "kind": "graycode",
        "orientation": "horizontal",
        "bit": 2,
        "bits": 4,
        "stripe": 114,
        "inverse": True,
        "code": "binary",
        "migl": 255,
        "convention": "x",
    }
    assert frame_from_manifest(entry) == f
    for bad in ({"bit": 4}, {"bits": 0}, {"stripe_px": -1.0}, {"code": "x"}, {"orientation": "d"}):
        args = {"orientation": "vertical", "bit": 0, "bits": 4, "stripe_px": 8.0, **bad}
        with pytest.raises(InputError):
            GrayCodeFrame(**args)


def test_captures_group_the_code_and_refuse_missing_or_unpaired_bits() -> None:
    frames = opencv_graycode_frames(64, 32, 8.0)
    sets = group_graycode_sets(frames)
    assert [(s.orientation, s.bits, s.inverse_indices is not None) for s in sets] == [
        ("vertical", 3, True),
        ("horizontal", 2, True),
    ]
    images = np.zeros((len(frames) - 1, 2, 2), np.uint8)
    with pytest.raises(CaptureFormatError, match="horizontal Gray code: bit 0 has no inverse"):
        Captures(frames[:-1], images, 8)
    with pytest.raises(CaptureFormatError, match=r"vertical Gray code: bit 2 of 0\.\.2 is missing"):
        Captures(frames[2:], np.zeros((len(frames) - 2, 2, 2), np.uint8), 8)
    with pytest.raises(CaptureFormatError, match="given twice"):
        group_graycode_sets([frames[0], frames[0]])


def test_capture_folder_version_3_round_trip_and_version_check(tmp_path: Path) -> None:
    frames = [*opencv_graycode_frames(32, 16, 8.0), UniformFrame(255), UniformFrame(0)]
    caps = Captures(frames, np.zeros((len(frames), 3, 4), np.uint8), 8, projector=ProjectorInfo())
    assert caps.format_version == 3
    folder = tmp_path / "caps"
    write_capture_folder(folder, caps)
    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["version"] == 3
    assert read_capture_folder(folder).frames == frames
    manifest["version"] = 2
    (folder / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(CaptureFormatError, match=r"kind 'graycode' needs capture format version 3"):
        read_capture_folder(folder)
    manifest["version"] = 3
    del manifest["frames"][2]  # bit 0 pattern of the vertical code (MSB first: b1, b1', b0, b0')
    (folder / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(
        CaptureFormatError, match=r"vertical Gray code: bit 0 of 0..1 is missing \(its inv"
    ) as err:
        read_capture_folder(folder)
    assert "\n" not in str(err.value)
    manifest["frames"][0]["stripe"] = 0
    (folder / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(CaptureFormatError, match="'stripe' must be positive"):
        read_capture_folder(folder)


def test_virtual_rig_renders_gray_code_that_decodes_to_the_projector_column() -> None:
    rig = SimulatedRig(plate(), seed=3)
    frames = [f for f in opencv_graycode_frames(1024, 768, 16.0) if f.orientation == "vertical"]
    images = rig.capture(frames).astype(float)
    d = decode_graycode(images[0::2][::-1], inverses=images[1::2][::-1], full_scale=255)
    truth = rig.truth()
    ok = d.valid & truth.valid
    assert ok.mean() > 0.8
    err = stripe_centre(d.index, 16.0) - truth.u
    assert np.mean(np.abs(err[ok]) <= 8.5) > 0.99


def test_spec_is_unaffected() -> None:
    """Fringe frames keep their manifests (version 1 when no Gray code is present)."""
    frames = FringeSpec(steps=3).frames()
    caps = Captures(frames, np.zeros((3, 2, 2), np.uint8), 8)
    assert caps.format_version == 1


# --- real data (../shared/realdata; skipped when absent) --------------------------------------
OBJECT1 = ("kamino410", "object1")
SPHERE = ("kimthyung_sphere",)

#: Camera boxes (rows, columns) inside each surface of kamino410 object1 (color.png): the wall
#: left of the sponge, the sponge's front face, the block under it, the wall right of the box.
OBJECT1_REGIONS = {
    "wall": (slice(100, 700), slice(150, 600)),
    "sponge": (slice(450, 980), slice(700, 1020)),
    "block": (slice(1070, 1200), slice(560, 1110)),
    "wall_right": (slice(100, 700), slice(1400, 1880)),
}


def _measured(what: str, value: object) -> None:
    print(f"[realdata] {what}: {value}")


def _object1_folder(root: Path, out: Path, graycode: bool = True) -> Path:
    """A version-3 capture folder of object1 (copies: the reader refuses symlinks leaving the
    folder). The 3-step shifts are -120/0/+120 degrees (pat00, pat01, pat02 of each set); the
    contract's equal shifts 0, 120, 240 degrees are pat01, pat02, pat00 (-120 = 240 degrees),
    an exact relabelling. Gray code: OpenCV's sequence on 100 px cells (pat12-29), white and
    black (pat30, pat31)."""
    import shutil

    out.mkdir(parents=True)
    frames: list[dict] = []

    def add(name: str, entry: dict) -> None:
        shutil.copyfile(root / name, out / name)
        frames.append({"file": name, **entry})

    for base, orient in ((0, "vertical"), (6, "horizontal")):
        for off, pitch in ((0, 200 / 3), (3, 100.0)):
            for k, shift in ((0, 2), (1, 0), (2, 1)):
                add(
                    f"pat{base + off + k:02d}.png",
                    {
                        "kind": "fringe",
                        "pattern": "sinusoidal",
                        "steps": 3,
                        "shift": shift,
                        "pitch": pitch,
                        "orientation": orient,
                        "imin": 0,
                        "migl": 255,
                    },
                )
    if graycode:
        for i, f in enumerate(opencv_graycode_frames(1920, 1080, 100.0)):
            entry = f.manifest_entry(f"pat{12 + i:02d}.png")
            add(entry.pop("file"), entry)
        add("pat30.png", {"kind": "uniform", "level": 255})
        add("pat31.png", {"kind": "uniform", "level": 0})
    manifest = {
        "format": "hdrfringe-captures",
        "version": 3 if graycode else 1,
        "camera": {"bit_depth": 8},
        "projector": {"width": 1920, "height": 1080, "bit_depth": 8},
        "frames": frames,
    }
    (out / "manifest.json").write_text(json.dumps(manifest, indent=1))
    return out


def _read_only(obj: object) -> None:
    """Every array reachable from ``obj`` (dataclasses, mappings, sequences) made read-only."""
    import dataclasses

    if isinstance(obj, np.ndarray):
        obj.setflags(write=False)
    elif dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        for f in dataclasses.fields(obj):
            _read_only(getattr(obj, f.name))
    elif isinstance(obj, dict):
        for v in obj.values():
            _read_only(v)
    elif isinstance(obj, list | tuple):
        for v in obj:
            _read_only(v)


@pytest.fixture(scope="module")
def object1_graycode(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """object1's version-3 folder (:func:`_object1_folder`, with the Gray code), read and
    decoded once for the module's two object1 tests (``caps``, ``decoded``; read-only arrays)."""
    from hdrfringe.core.decode import decode_captures
    from tests.conftest import realdata_path

    root = realdata_path(*OBJECT1)
    caps = read_capture_folder(_object1_folder(root, tmp_path_factory.mktemp("object1") / "caps"))
    decoded = decode_captures(caps)
    _read_only(caps)
    _read_only(decoded)
    return {"root": root, "caps": caps, "decoded": decoded}


@pytest.mark.realdata
def test_object1_graycode_gives_sponge_block_and_wall_their_own_orders(
    object1_graycode: dict,
) -> None:
    """Gray code + phase: every surface gets the fringe order of the Gray code alone and the
    projector coordinate of kamino410's own decode (vizualized.png holds it modulo 256:
    blue = x, green = y, red = 128 where decoded)."""
    import cv2

    root, caps, decoded = (object1_graycode[k] for k in ("root", "caps", "decoded"))
    viz = cv2.imread(str(root / "vizualized.png"), cv2.IMREAD_UNCHANGED)
    theirs_ok = viz[..., 2] == 128
    codes = {g.orientation: g for g in caps.graycode_sets()}
    images = caps.images.astype(float)
    for fam, channel in zip(decoded.families, (0, 1), strict=True):
        assert fam.unwrapping == "graycode" and not fam.islands
        x = fam.absolute_phase * fam.pitch_px / TWO_PI
        g = codes[fam.orientation]
        alone = decode_graycode(
            images[list(g.frame_indices)], inverses=images[list(g.inverse_indices)]
        )
        x_gc = stripe_centre(alone.index, g.stripe_px)
        for name, box in OBJECT1_REGIONS.items():
            ours = x[box]
            ok = np.isfinite(ours) & theirs_ok[box]
            diff = np.mod(ours[ok] - viz[..., channel][box][ok] + 128, 256) - 128
            # their x is truncated to an integer: ours - theirs lies in [0, 1) when both agree
            med = float(np.median(diff))
            same = np.isfinite(x_gc[box]) & np.isfinite(ours)
            order_ok = np.abs(ours[same] - x_gc[box][same]) <= g.stripe_px / 2 + 2
            _measured(
                f"object1 {fam.orientation} {name}",
                f"median x - kamino410 x = {med:.2f} px ({ok.sum()} px), "
                f"order = Gray code alone at {100 * order_ok.mean():.2f} %",
            )
            assert ok.sum() > 20000
            assert 0.0 <= med < 1.0  # measured 0.50-0.52 in every region
            assert np.mean(np.abs(diff - 0.5) < 2) > 0.95
            assert order_ok.mean() > 0.99


@pytest.mark.realdata
def test_object1_spatial_only_reports_islands(object1_graycode: dict, tmp_path: Path) -> None:
    """Without the Gray code the same images unwrap spatially: the block's fringe order is off
    the wall's (measured 600 px) and the decode says the relative order is unknown, in the
    terminal (phase, measure), phase_summary.json, metrics.json and regions.tiff."""
    import tifffile

    from tests.conftest import run_cli

    folder = _object1_folder(object1_graycode["root"], tmp_path / "caps", graycode=False)
    # no previews nor report: nothing here reads them (tests/test_replay_realdata.py's runs of
    # object1 write reports)
    quiet = ("--no-previews", "--no-report")
    res = run_cli("phase", str(folder), *quiet, "-o", str(tmp_path / "phase"), timeout=300)
    assert res.returncode == 0, res.stderr
    assert "vertical fringes: the valid area falls into 2 separate regions" in res.stdout
    summary = json.loads((tmp_path / "phase" / "phase_summary.json").read_text())
    vert = summary["families"][0]
    assert vert["order_from"] == "spatial" and vert["regions"]["islands"]
    labels = tifffile.imread(tmp_path / "phase" / vert["regions_map"])
    assert labels.dtype == np.uint16
    wall = np.bincount(labels[OBJECT1_REGIONS["wall"]].ravel()).argmax()
    block = np.bincount(labels[OBJECT1_REGIONS["block"]].ravel()).argmax()
    sponge = np.bincount(labels[OBJECT1_REGIONS["sponge"]].ravel()).argmax()
    assert wall == 1 and block not in (0, wall)
    # The sponge's top edge is a step of 403 px = 4.03 periods of 100 px and 6.05 of 66.67 px:
    # continuous in both wrapped phases, so no spatial method can separate it from the wall.
    _measured("object1 spatial regions (wall, sponge, block)", (int(wall), int(sponge), int(block)))
    # the spatial orders are wrong (compared with the Gray code decode of the full folder)
    unwrapped = tifffile.imread(tmp_path / "phase" / vert["unwrapped_phase"]) * (200 / 3) / TWO_PI
    full = object1_graycode["decoded"]  # the folder with the Gray code
    x = full.primary.absolute_phase * full.primary.pitch_px / TWO_PI
    off = {name: float(np.nanmedian((unwrapped - x)[box])) for name, box in OBJECT1_REGIONS.items()}
    _measured(
        "object1 spatial - Gray code x per region (px)", {k: round(v) for k, v in off.items()}
    )
    assert abs(off["block"] - off["wall"]) > 50  # measured about 600 px
    res = run_cli("measure", str(folder), *quiet, "-o", str(tmp_path / "measure"), timeout=300)
    assert res.returncode == 0, res.stderr
    assert "separate regions" in res.stdout
    metrics = json.loads((tmp_path / "measure" / "metrics.json").read_text())
    assert metrics["regions"]["islands"] and metrics["regions"]["count"] == 2
    assert len(metrics["regions"]["pixels"]) == 2


@pytest.mark.realdata
def test_sphere_graycode_counts_10_periods_over_1140_rows(tmp_path: Path) -> None:
    """kimthyung_sphere: plain binary-reflected Gray code, bit 0 (finest) first (03, 04, ...),
    lit = 1, no inverses and no white frame: the bits are decided against the mean intensity of
    the 3-step set of the same orientation (the level halfway between its dark and bright
    stripes, both fringe and code spanning 0..255). The stripe indices stop at 9 (horizontal;
    7 vertical), and every stripe edge sits at one fringe phase: one period per 114-row
    stripe, 10 periods over the 1140 projector rows (8 over 912 columns)."""
    import shutil

    from hdrfringe.core.decode import decode_captures
    from tests.conftest import realdata_path

    root = realdata_path(*SPHERE)
    folder = tmp_path / "caps"
    folder.mkdir()
    frames: list[dict] = []
    for sub, orient, bits, black in (
        ("verti_test", "vertical", 3, 6),
        ("hori_test", "horizontal", 4, 7),
    ):

        def add(i: int, entry: dict, sub=sub, orient=orient) -> None:
            name = f"{orient[0]}{i:02d}.png"
            shutil.copyfile(root / sub / f"{i:02d}.png", folder / name)
            frames.append({"file": name, **entry})

        for i in range(3):
            add(
                i,
                {
                    "kind": "fringe",
                    "pattern": "sinusoidal",
                    "steps": 3,
                    "shift": i,
                    "pitch": 114,
                    "orientation": orient,
                    "imin": 0,
                    "migl": 255,
                },
            )
        for b in range(bits):
            add(
                3 + b,
                {"kind": "graycode", "orientation": orient, "bit": b, "bits": bits, "stripe": 114},
            )
        add(black, {"kind": "uniform", "level": 0})
    manifest = {
        "format": "hdrfringe-captures",
        "version": 3,
        "camera": {"bit_depth": 8},
        "projector": {"width": 912, "height": 1140, "bit_depth": 8},
        "frames": frames,
    }
    (folder / "manifest.json").write_text(json.dumps(manifest))
    caps = read_capture_folder(folder)
    decoded = decode_captures(caps)
    assert all(f.unwrapping == "graycode" for f in decoded.families)
    assert all("mean intensity of the coarsest fringe set" in f.method for f in decoded.families)
    images = caps.images.astype(float)
    for g, s, cells in zip(caps.graycode_sets(), caps.sets, (8, 10), strict=True):
        r = decoded.set_results[s.label]
        d = decode_graycode(
            images[list(g.frame_indices)],
            threshold=r.mean_intensity,
            contrast=2 * r.modulation,
        )
        seen = np.unique(d.index[d.valid]).astype(int)
        _measured(f"sphere {g.orientation} stripe indices", seen.tolist())
        assert seen.max() == cells - 1 and d.valid.mean() > 0.4
        # the wrapped phase where the stripe index steps by one (decided bits, lit pixels)
        loose = decode_graycode(
            images[list(g.frame_indices)], threshold=r.mean_intensity, min_contrast=0.0
        )
        idx = np.where(r.modulation > 10, loose.index, np.nan)
        axis = 1 if g.orientation == "vertical" else 0
        a, p = np.moveaxis(idx, axis, 0), np.moveaxis(r.wrapped_phase, axis, 0)
        edge = (np.abs(a[1:] - a[:-1]) == 1) & np.isfinite(p[1:]) & np.isfinite(p[:-1])
        z = np.exp(1j * p[1:][edge]) + np.exp(1j * p[:-1][edge])  # mean of the two sides
        z /= np.abs(z)
        lower = np.minimum(a[1:], a[:-1])[edge]
        means = {
            int(m): np.angle(z[lower == m].mean())
            for m in np.unique(lower)
            if (lower == m).sum() > 100
        }
        _measured(
            f"sphere {g.orientation} phase at stripe edges (rad)",
            {k: round(float(v), 2) for k, v in means.items()},
        )
        overall = np.angle(z.mean())
        assert len(means) >= 5
        assert all(abs(np.angle(np.exp(1j * (v - overall)))) < 0.3 for v in means.values())
