"""Folder-level decoding: families, temporal after spatial unwrapping, centerline absolute phase."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hdrfringe.frames import CenterlineFrame
from hdrfringe.io.captures import read_capture_folder, simulate_to_folder
from hdrfringe.patterns import FringeSpec
from hdrfringe.process import decode_captures
from hdrfringe.rig.scenes import mask
from hdrfringe.rig.simulated import SimulatedRig


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
