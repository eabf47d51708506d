"""Each real data set imported by one ``hdrfringe import`` call with its description in
docs/examples/import, then decoded by ``hdrfringe phase``: the maps equal those of a hand-written
manifest (tests/test_realdata.py's specs and conventions, docs/realdata.md).

The references are built here without the importer: a version-1 manifest written out by hand
over copies of the images (as ``test_pyramid_cli_phase`` does), or the arrays read straight from
the source files and decoded with :func:`hdrfringe.core.phase.decode_set` and the specs of
tests/test_realdata.py. Where a description declares what a version-1 manifest cannot hold (a
sine profile, shifted angles) the reference is the version-1 decode plus the documented constant
(docs/realdata.md: the checkerboard's sine decodes to ``2*pi*F*x - pi/2``). Every test skips
when ``../shared/realdata`` is absent.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.core.decode import decode_captures
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.phase import PhaseResult, decode_set, default_min_modulation, sinusoidal_phase
from hdrfringe.io.captures import load_image, read_capture_folder
from hdrfringe.io.results import read_map_tiff
from tests.conftest import realdata_path, run_cli

pytestmark = pytest.mark.realdata

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "docs" / "examples" / "import"
TWO_PI = 2 * np.pi


def wrapped_diff(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.mod(np.asarray(a, np.float64) - np.asarray(b, np.float64) + np.pi, TWO_PI) - np.pi


def import_and_phase(name: str, images: Path, tmp_path: Path) -> tuple[dict, Path, Path]:
    """``hdrfringe import`` (one call, the kept description), then the ``next:`` command it
    printed, which must be ``hdrfringe phase`` (tests/test_next_hints.py): with every set's maps,
    and without the PNG previews and the report, which no test here reads (at these 1-5 Mpx
    they were a third of the command's time; tests/test_previews.py and tests/test_report.py
    test them)."""
    from tests.test_next_hints import run_hint

    caps, out = tmp_path / "caps", tmp_path / "phase"
    res = run_cli("import", str(images), "-d", str(EXAMPLES / f"{name}.toml"), "-o", str(caps))
    assert res.returncode == 0, res.stderr
    command, res = run_hint(res.stdout, out, "--per-set-maps", "--no-previews", "--no-report")
    assert command == "phase" and res.returncode == 0, res.stderr
    return json.loads((out / "phase_summary.json").read_text()), caps, out


def set_map(out: Path, kind: str, summary: dict, pitch: float, orientation: str) -> np.ndarray:
    """The CLI's map of one set, found by pitch and orientation in phase_summary.json."""
    (s,) = [
        s
        for s in summary["sets"]
        if abs(s["pitch_px"] - pitch) < 1e-6 and s["orientation"] == orientation
    ]
    path = out / f"{kind}__{s['label']}.tiff"
    if len(summary["sets"]) == 1 and not path.exists():  # one set: maps without a suffix
        path = out / f"{kind}.tiff"
    return read_map_tiff(path)


def handwritten(tmp_path: Path, root: Path, frames: list[dict], bit_depth: int, **top) -> Path:
    """A capture folder of copied images and a version-1 manifest written out by hand."""
    caps = tmp_path / "handwritten"
    caps.mkdir()
    for f in frames:
        shutil.copyfile(root / f["src"], caps / f["file"])
    manifest = {
        "format": "hdrfringe-captures",
        "version": 1,
        "camera": {"bit_depth": bit_depth},
        **top,
        "frames": [{k: v for k, v in f.items() if k != "src"} for f in frames],
    }
    (caps / "manifest.json").write_text(json.dumps(manifest, indent=1))
    return caps


def fringe(src: str, steps: int, shift: int, pitch: float, orientation: str) -> dict:
    return {
        "src": src,
        "file": src.replace("/", "_"),
        "kind": "fringe",
        "pattern": "sinusoidal",
        "steps": steps,
        "shift": shift,
        "pitch": pitch,
        "orientation": orientation,
        "imin": 0,
        "migl": 255,
    }


def assert_offset_of(ours: np.ndarray, ref: PhaseResult, imgs: np.ndarray, constant: float) -> None:
    """``ours`` is the version-1 decode ``ref`` plus ``constant`` (mod 2*pi), with the same valid
    pixels except where the modulation sits exactly on the threshold: the shifted-angle decoder
    (a least-squares fit) and Eq. 2.2 differ there by ~1e-13 DN, which decides such ties either
    way (8-bit images give many pixels of modulation exactly 2 DN)."""
    _, modulation, _ = sinusoidal_phase(imgs)
    tie = np.abs(modulation - default_min_modulation(8)) < 1e-9
    valid = np.isfinite(ours)
    np.testing.assert_array_equal(valid[~tie], ref.valid[~tie])
    both = valid & ref.valid
    assert both.sum() > 0.3 * valid.size  # not vacuous (the checkerboard: 42 % valid)
    d = wrapped_diff(ours[both], ref.wrapped_phase[both] + constant)
    assert np.abs(d).max() < 1e-5, np.abs(d).max()


def assert_same_as_handwritten(summary: dict, out: Path, reference: Path) -> None:
    """Every set's maps and every family's unwrapped phase equal the hand-written folder's
    (decoded as ``phase`` decodes by default: maps stored in float32)."""
    dec = decode_captures(read_capture_folder(reference), map_dtype="float32")
    assert len(summary["sets"]) == len(dec.sets)
    for fs in dec.sets:
        res = dec.set_results[fs.label]
        for kind, ref in (
            ("wrapped_phase", res.wrapped_phase),
            ("modulation", res.modulation),
            ("saturation_count", res.saturation_count),
        ):
            ours = set_map(out, kind, summary, fs.spec.pitch_px, fs.spec.orientation)
            np.testing.assert_array_equal(ours, np.asarray(ref).astype(ours.dtype), err_msg=kind)
    for fam, ref in zip(summary["families"], dec.families, strict=True):
        assert fam["orientation"] == ref.orientation
        ours = read_map_tiff(out / fam["unwrapped_phase"])
        np.testing.assert_array_equal(ours, ref.unwrapped_phase.astype(ours.dtype))


# =============================================================================================


def test_thomriiii_pyramid(tmp_path: Path) -> None:
    """8-step cosine, RGB: identical to the hand-written manifest of test_pyramid_cli_phase."""
    root = realdata_path("thomriiii", "apr2026_pyramid_8step")
    summary, _, out = import_and_phase("thomriiii_pyramid", root, tmp_path)
    extent = {"vertical": 1920, "horizontal": 1080}
    frames = [
        fringe(f"images/{o}/f_{f:03d}/step_{k:03d}.png", 8, k, extent[o] / f, o)
        for o in ("vertical", "horizontal")
        for f in (1, 4, 16)
        for k in range(8)
    ]
    ref = handwritten(
        tmp_path, root, frames, 8, projector={"width": 1920, "height": 1080, "bit_depth": 8}
    )
    assert_same_as_handwritten(summary, out, ref)
    assert [f["unwrapping"][:8] for f in summary["families"]] == ["temporal"] * 2


def test_kamino410_gamma(tmp_path: Path) -> None:
    """-120/0/+120 degrees: the hand-written manifest numbers them 2, 0, 1 (docs/import.md).

    The folder decodes (``phase`` refused it before issue 31: "pitches must be strictly
    decreasing"): sets of one orientation and pitch that differ in their gamma
    pre-compensation are separate families, not one pitch ladder; every set is decoded, each
    family unwrapped within itself, and a note names the other sets (the command line on
    such a folder: tests/test_next_hints.py; ``decode_captures`` here, 2.8 s, where ``phase``
    writing its maps took 10 s more). The round trip compares the folders read back and every
    set decoded.
    """
    root = realdata_path("kamino410", "gamma_correction_subset")
    caps = tmp_path / "caps"
    res = run_cli(
        "import", str(root), "-d", str(EXAMPLES / "kamino410_gamma.toml"), "-o", str(caps)
    )
    assert res.returncode == 0, res.stderr
    from tests.test_next_hints import run_hint

    command, ran = run_hint(res.stdout, tmp_path / "gamma")  # gamma: what the sets are for
    assert command == "gamma" and ran.returncode == 0, ran.stderr
    frames = []
    sets = ((0, "vertical", 0.75), (3, "vertical", 1.25), (6, "horizontal", 0.75))
    for base, o, gamma in (*sets, (9, "horizontal", 1.25)):
        for j, shift in enumerate((2, 0, 1)):
            f = fringe(f"pat{base + j:02d}.png", 3, shift, 240.0, o)
            frames.append({**f, "gamma_precompensation": gamma})
    frames += [
        {"src": "pat52.png", "file": "pat52.png", "kind": "uniform", "level": 255},
        {"src": "pat53.png", "file": "pat53.png", "kind": "uniform", "level": 0},
    ]
    ref = read_capture_folder(
        handwritten(tmp_path, root, frames, 8, projector={"width": 1920, "height": 1080})
    )
    assert json.loads((caps / "manifest.json").read_text())["version"] == 1
    imported = read_capture_folder(caps)
    assert imported.frames == ref.frames
    assert imported.gamma_precompensation == ref.gamma_precompensation
    np.testing.assert_array_equal(imported.images, ref.images)
    assert [s.label for s in imported.sets] == [s.label for s in ref.sets]
    decoded = decode_captures(imported)
    assert [[s.label for s in f.sets] for f in decoded.families] == [
        ["s3_p240_v_i0_g255_gp0.75"],
        ["s3_p240_h_i0_g255_gp0.75"],
    ]
    assert [f.method for f in decoded.families] == ["spatial", "spatial"]
    assert sum("s3_p240_v_i0_g255_gp1.25 (gamma pre-compensation 1.25)" in n
               for n in decoded.notes) == 1  # fmt: skip
    # the other exponent's sets: each a family unwrapped within itself (issue 31)
    assert [[s.label for s in f.sets] for f in decoded.gamma_families] == [
        ["s3_p240_v_i0_g255_gp1.25"],
        ["s3_p240_h_i0_g255_gp1.25"],
    ]
    assert [f.method for f in decoded.gamma_families] == ["spatial", "spatial"]
    for a, b in zip(imported.sets, ref.sets, strict=True):
        ra = decoded.set_results[a.label]
        assert np.mean(ra.valid) > 0.8  # 87 % measured
        rb = decode_set(ref.set_images(b), b.spec, 8)
        np.testing.assert_array_equal(ra.wrapped_phase, rb.wrapped_phase)
        np.testing.assert_array_equal(ra.modulation, rb.modulation)


def test_kamino410_object1(tmp_path: Path) -> None:
    """Fringe sets identical to a hand-written manifest; the Gray code is the OpenCV sequence."""
    from hdrfringe.core.frames import opencv_graycode_frames

    root = realdata_path("kamino410", "object1")
    summary, caps, out = import_and_phase("kamino410_object1", root, tmp_path)
    manifest = json.loads((caps / "manifest.json").read_text())
    assert manifest["version"] == 3
    # the Gray-code frames are exactly OpenCV's sequence on the 100 px grid, in file order
    files = [f["file"] for f in manifest["frames"] if f["kind"] == "graycode"]
    assert files == [f"pat{i:02d}.png" for i in range(12, 30)]
    imported = read_capture_folder(caps)
    assert imported.frames[12:30] == opencv_graycode_frames(1920, 1080, 100)
    assert len(imported.graycode_sets()) == 2
    frames = []
    for base, o, periods in (
        (0, "vertical", (28.8, 19.2)),
        (6, "horizontal", (16.2, 10.8)),
    ):
        extent = 1920 if o == "vertical" else 1080
        for n, p in enumerate(periods):
            for j, shift in enumerate((2, 0, 1)):
                frames.append(fringe(f"pat{base + 3 * n + j:02d}.png", 3, shift, extent / p, o))
    ref = handwritten(tmp_path, root, frames, 8, projector={"width": 1920, "height": 1080})
    dec = decode_captures(read_capture_folder(ref))
    for fs in dec.sets:
        ours = set_map(out, "wrapped_phase", summary, fs.spec.pitch_px, fs.spec.orientation)
        theirs = dec.set_results[fs.label].wrapped_phase.astype(np.float32)
        np.testing.assert_array_equal(ours, theirs)


def test_napari_eyeglasses(tmp_path: Path) -> None:
    """The 16-bit .npz stack converted losslessly: maps equal decode_set on the stack itself."""
    root = realdata_path("napari_profilometry")
    summary, caps, out = import_and_phase("napari_eyeglasses", root, tmp_path)
    with np.load(root / "ex_single_image_large_uint16.npz") as z:
        frames = z["frames"]
    np.testing.assert_array_equal(read_capture_folder(caps).images, frames)
    ref = decode_set(frames, FringeSpec("sinusoidal", 3, 14.5, "vertical", 0, 255), 16)
    for kind in ("wrapped_phase", "modulation", "saturation_count"):
        ours = set_map(out, kind, summary, 14.5, "vertical")
        np.testing.assert_array_equal(ours, getattr(ref, kind).astype(ours.dtype))
    assert int((ours > 0).sum()) == 311  # README: 311 clipped pixels


def test_thomriiii_checkerboard(tmp_path: Path) -> None:
    """Sine profile: the imported wrapped phase is test_realdata's version-1 decode + pi/2."""
    root = realdata_path("thomriiii", "dec2025_checkerboard_saturated_4step")
    summary, _, out = import_and_phase("thomriiii_checkerboard", root, tmp_path)
    for o, prefix, extent in (("vertical", "scan", 1920), ("horizontal", "scanh", 1080)):
        for f in (4, 8, 16, 32):
            imgs = np.stack(
                [
                    load_image(root / "images" / f"{prefix}_f{f:03d}_n{k:02d}.png", 8)
                    for k in range(4)
                ]
            )
            ref = decode_set(imgs, FringeSpec("sinusoidal", 4, extent / f, o, 0, 255), 8)  # type: ignore[arg-type]
            ours = set_map(out, "wrapped_phase", summary, extent / f, o)
            assert_offset_of(ours, ref, imgs, np.pi / 2)
            np.testing.assert_array_equal(
                set_map(out, "saturation_count", summary, extent / f, o), ref.saturation_count
            )
    # the offset declared, the CLI unwraps the four frequencies temporally (docs/realdata.md)
    assert all(f["unwrapping"].startswith("temporal") for f in summary["families"])


def test_kimthyung_sphere(tmp_path: Path) -> None:
    """Sine with offsets: the vertical set (sine, phase_offset_deg = 60: manifest offset -30)
    is the version-1 decode + pi/6, the horizontal one (s = -90, 30, -210 degrees on a sine,
    phase_offset_deg = 180: manifest offset 90) the version-1 decode of shifts 0, 1, 2
    (+ pi - pi). The offsets put phase 0 on the Gray-code stripe edges (tests/
    test_sphere_realdata.py)."""
    root = realdata_path("kimthyung_sphere")
    summary, caps, out = import_and_phase("kimthyung_sphere", root, tmp_path)
    assert len(read_capture_folder(caps).graycode_sets()) == 2
    for folder, o, constant in (
        ("verti_test", "vertical", np.pi / 6),
        ("hori_test", "horizontal", 0.0),
    ):
        imgs = np.stack([load_image(root / folder / f"{k:02d}.png", 8) for k in range(3)])
        ref = decode_set(imgs, FringeSpec("sinusoidal", 3, 114.0, o, 0, 255), 8)  # type: ignore[arg-type]
        assert_offset_of(set_map(out, "wrapped_phase", summary, 114.0, o), ref, imgs, constant)
