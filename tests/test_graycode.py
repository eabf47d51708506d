"""Gray code: patterns, decoding, absolute phase with edge errors, frames, manifests, real data."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.captures import Captures, ProjectorInfo, group_graycode_sets
from hdrfringe.errors import CaptureFormatError, InputError
from hdrfringe.frames import (
    GrayCodeFrame,
    UniformFrame,
    frame_from_manifest,
    opencv_graycode_frames,
)
from hdrfringe.graycode import (
    absolute_phase_graycode,
    binary_to_gray,
    bits_needed,
    code_bit,
    decode_graycode,
    gray_to_binary,
    graycode_patterns,
    stripe_centre,
)
from hdrfringe.io.captures import read_capture_folder, write_capture_folder
from hdrfringe.patterns import FringeSpec
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
    # the naive rule "order = stripe index" is wrong near every phase wrap, too
    naive = index - np.round((stripe_centre(index, 100.0) - 49.5) / 100.0)
    assert (naive != truth_k).mean() > wrong.mean()


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
