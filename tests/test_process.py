"""Folder-level decoding: families, temporal after spatial unwrapping, centerline absolute phase,
Gray code + phase, islands."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hdrfringe.core.captures import Captures, ProjectorInfo
from hdrfringe.core.decode import decode_captures
from hdrfringe.core.frames import CenterlineFrame, UniformFrame, opencv_graycode_frames
from hdrfringe.core.patterns import FringeSpec, fringe_gray
from hdrfringe.io.captures import read_capture_folder
from hdrfringe.io.phase_maps import write_phase_maps
from hdrfringe.rig.scenes import mask
from hdrfringe.rig.simulated import SimulatedRig
from hdrfringe.tasks.simulate import simulate_to_folder


@pytest.fixture(scope="module")
def two_pitch_folder(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, SimulatedRig]:
    """Mask on the default (noisy, blurred) rig, pitches 48 and 8 with no one-period set."""
    rig = SimulatedRig(mask(), seed=5)
    frames = [
        *FringeSpec("sinusoidal", 4, 48.0).frames(),
        *FringeSpec("sinusoidal", 4, 8.0).frames(),
        *FringeSpec("sinusoidal", 4, 8.0, "horizontal").frames(),
        CenterlineFrame(512, "vertical", 255),
    ]
    path = tmp_path_factory.mktemp("proc") / "caps"
    simulate_to_folder(path, rig, frames)
    return path, rig


def test_spatial_then_temporal_then_centerline(two_pitch_folder) -> None:
    path, rig = two_pitch_folder
    decoded = decode_captures(read_capture_folder(path))
    fam = decoded.primary
    assert fam is not None and fam.orientation == "vertical"
    assert [s.spec.pitch_px for s in fam.sets] == [48.0, 8.0]
    assert fam.method.startswith("temporal 48 -> 8 px (spatial first)")
    truth = rig.truth()
    ok = truth.valid & np.isfinite(fam.absolute_phase)
    assert ok.mean() > 0.98
    err_px = (fam.absolute_phase - 2 * np.pi * truth.u / 8.0)[ok] * 8.0 / (2 * np.pi)
    assert np.mean(np.abs(err_px) > 4.0) < 1e-3  # fringe order right almost everywhere
    assert np.sqrt(np.mean(err_px[np.abs(err_px) < 4.0] ** 2)) < 0.1
    # the horizontal family has no horizontal centerline: unwrapped, but no absolute phase
    horiz = decoded.families[1]
    assert horiz.orientation == "horizontal" and horiz.absolute_phase is None
    assert any("horizontal" in n for n in decoded.notes)


# --- Gray code and islands ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def graycode_rig() -> tuple[SimulatedRig, Captures]:
    """The mask on the default (noisy, blurred) rig: one 3-step set of pitch 16 px (no
    one-period set, no centerline), OpenCV's Gray code on 16 px cells, white and black."""
    rig = SimulatedRig(mask(), seed=7)
    frames = [
        *FringeSpec("sinusoidal", 3, 16.0, imin=0, migl=255).frames(),
        *opencv_graycode_frames(1024, 768, 16.0),
        UniformFrame(255),
        UniformFrame(0),
    ]
    return rig, rig.capture_folder(frames)


def _order_errors(fam, rig) -> tuple[np.ndarray, np.ndarray]:
    truth = rig.truth()
    ok = truth.valid & np.isfinite(fam.absolute_phase)
    err_px = (
        (fam.absolute_phase - 2 * np.pi * truth.u / fam.pitch_px)[ok] * fam.pitch_px / (2 * np.pi)
    )
    return ok, err_px


def test_graycode_gives_the_absolute_phase_pixel_by_pixel(graycode_rig) -> None:
    rig, caps = graycode_rig
    decoded = decode_captures(caps)
    fam = decoded.primary
    assert fam.unwrapping == "graycode" and fam.regions is None and not fam.islands
    assert fam.method.startswith("Gray code + phase (phase-guided order, 7x7 median cleanup")
    assert "pattern/inverse pairs" in fam.method
    assert fam.absolute_method == "Gray code (6 bits, stripe 16 px) + phase of the 16 px set"
    ok, err_px = _order_errors(fam, rig)
    assert ok.mean() > 0.9
    assert np.mean(np.abs(err_px) > 8.0) < 1e-4  # fringe order right at (nearly) every pixel
    assert np.sqrt(np.mean(err_px[np.abs(err_px) < 8.0] ** 2)) < 0.2
    # without the Gray code frames the same set is unwrapped spatially and is not absolute
    keep = [i for i, f in enumerate(caps.frames) if f.kind != "graycode"]
    plain = Captures([caps.frames[i] for i in keep], caps.images[keep], 8, projector=caps.projector)
    alone = decode_captures(plain).primary
    assert alone.unwrapping == "spatial" and alone.absolute_phase is None


def test_graycode_thresholds_without_inverses(graycode_rig) -> None:
    """Patterns only: bits against (white + black)/2, or, without a white frame, against the
    fringe set's mean intensity; both give the order of the inverse-pair decode."""
    rig, caps = graycode_rig
    no_inv = [i for i, f in enumerate(caps.frames) if not getattr(f, "inverse", False)]
    frames = [caps.frames[i] for i in no_inv]
    white_black = Captures(frames, caps.images[no_inv], 8, projector=caps.projector)
    fam = decode_captures(white_black).primary
    assert "against (white + black)/2" in fam.method
    ok, err_px = _order_errors(fam, rig)
    assert ok.mean() > 0.9 and np.mean(np.abs(err_px) > 8.0) < 1e-3
    no_white = [i for i in no_inv if caps.frames[i] != UniformFrame(255)]
    mean_thr = Captures(
        [caps.frames[i] for i in no_white], caps.images[no_white], 8, projector=caps.projector
    )
    fam = decode_captures(mean_thr).primary
    assert "mean intensity of the coarsest fringe set" in fam.method
    ok, err_px = _order_errors(fam, rig)
    assert ok.mean() > 0.9 and np.mean(np.abs(err_px) > 8.0) < 1e-3


def _ramp_captures(x: np.ndarray, frames_extra=(), images_extra=(), pitches=(16.0,)):
    frames, images = [], []
    for p in pitches:
        spec = FringeSpec("sinusoidal", 4, p, imin=20, migl=220)
        for f in spec.frames():
            frames.append(f)
            images.append(np.rint(np.nan_to_num(fringe_gray(x, spec, f.shift), nan=20.0)))
    frames += list(frames_extra)
    images += list(images_extra)
    return Captures(
        frames,
        np.stack(images).astype(np.uint8),
        8,
        projector=ProjectorInfo(width=1024, height=768),
    )


def test_one_period_set_wins_over_graycode_and_a_wide_stripe_is_not_used() -> None:
    x = np.tile(np.arange(300.0) + 10, (20, 1))
    gc = [f for f in opencv_graycode_frames(1024, 768, 32.0) if f.orientation == "vertical"]
    gimg = [np.rint(f.gray(x)).astype(np.uint8) for f in gc]
    caps = _ramp_captures(x, gc, gimg, pitches=(1024.0, 16.0))
    fam = decode_captures(caps).primary
    assert fam.unwrapping == "one-period" and fam.absolute_method == "one-period coarse set"
    caps = _ramp_captures(x, gc, gimg, pitches=(16.0,))
    decoded = decode_captures(caps)
    assert decoded.primary.unwrapping == "spatial"
    assert any(
        "stripe (32 px) is wider than the coarsest pitch (16 px)" in n for n in decoded.notes
    )


def test_islands_are_reported_with_a_region_map(tmp_path: Path) -> None:
    """A ramp cut by an unlit band and a step of 2.5 periods: three regions whose relative
    order spatial unwrapping cannot know; said in the notes, the summary and a label map."""
    x = np.tile(np.arange(400.0), (60, 1))
    x[:, 250:] += 40.0  # a depth step of 2.5 periods: the phase jumps by pi
    x[:, 120:126] = np.nan  # unlit: no modulation
    caps = _ramp_captures(x)
    decoded = decode_captures(caps)
    fam = decoded.primary
    assert fam.unwrapping == "spatial" and fam.islands
    assert fam.regions.significant == 3
    assert sorted(fam.regions.sizes[:3]) == sorted([60 * 120, 60 * 124, 60 * 150])
    assert any("falls into 3 separate regions" in n for n in decoded.notes)
    labels = fam.regions.labels
    assert set(np.unique(labels[:, :120])) == {labels[0, 0]} and (labels[:, 120:126] == 0).all()
    assert labels[0, 0] != labels[0, 200] != labels[0, 300] != labels[0, 0]
    summary = write_phase_maps(tmp_path, decoded, "memory")
    (entry,) = summary["families"]
    assert entry["order_from"] == "spatial" and entry["regions_map"] == "regions_vertical.tiff"
    assert entry["regions"]["islands"] and entry["regions"]["count"] == 3
    import tifffile

    written = tifffile.imread(tmp_path / "regions_vertical.tiff")
    assert written.dtype == np.uint16 and np.array_equal(written, labels)
    # one connected, continuous ramp: one region, no note, no map
    smooth = decode_captures(_ramp_captures(np.tile(np.arange(400.0), (60, 1))))
    assert not smooth.primary.islands and smooth.primary.regions.significant == 1
    assert not any("separate regions" in n for n in smooth.notes)
