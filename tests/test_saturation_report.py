"""The terminal reports saturated pixels as a count and a share (issue 12, point 8): a share
alone printed "0.0 %" when a few hundred pixels of a large image clipped."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hdrfringe.core._validation import describe_saturated
from hdrfringe.core.captures import Captures, ProjectorInfo
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.io.captures import write_capture_folder
from tests.conftest import run_cli, synthetic_set

SHAPE = (200, 240)  # 48 000 pixels: 7 clipped are 0.015 %, "0.0 %" to one decimal
CLIPPED = [(10, 10), (10, 11), (50, 100), (120, 7), (150, 200), (199, 239), (0, 0)]


def _folder(path: Path) -> tuple[Path, np.ndarray]:
    spec = FringeSpec("sinusoidal", 4, 8.0, "vertical", 40, 200)
    imgs, _ = synthetic_set(spec, SHAPE)
    for k, (r, c) in enumerate(CLIPPED):
        imgs[k % 4, r, c] = 255  # one clipped shift each
    caps = Captures(spec.frames(), imgs, 8, projector=ProjectorInfo(1024, 768, 8, 2.812))
    write_capture_folder(path, caps)
    return path, imgs


def test_describe_saturated() -> None:
    assert describe_saturated(311, 4_400_000) == "311 px (0.0071 %)"
    assert describe_saturated(7, 48_000) == "7 px (0.015 %)"
    assert describe_saturated(0, 48_000) == "0 px (0 %)"
    assert describe_saturated(12_000, 48_000) == "12000 px (25.0 %)"


def test_phase_and_modify_print_the_count(tmp_path: Path) -> None:
    folder, imgs = _folder(tmp_path / "caps")
    res = run_cli("phase", str(folder), "-o", str(tmp_path / "p"))
    assert res.returncode == 0, res.stderr
    text = " ".join(res.stdout.split())  # rich wraps long lines
    assert f"saturated {len(CLIPPED)} px (0.015 %)" in text, text
    assert "saturated 0.0 %" not in text  # what it printed before
    res = run_cli("modify", str(folder), "-o", str(tmp_path / "m"), "--add-dn", "80")
    assert res.returncode == 0, res.stderr
    expected = int(np.count_nonzero((imgs.astype(int) + 80 >= 255).any(axis=0)))
    assert len(CLIPPED) < expected < imgs[0].size  # a reference computed here
    text = " ".join(res.stdout.split())
    assert f"({describe_saturated(expected, imgs[0].size)} saturated)" in text, text
