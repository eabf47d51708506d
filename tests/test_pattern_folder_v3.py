"""Pattern folders of version-3 frames (Gray code, shift angles, a phase offset) read back.

``hdrfringe patterns`` itself plays only the contract's fringes, centerlines and uniform grays
(it has no option for Gray code, shift angles or an offset), but
:func:`hdrfringe.io.pattern_folder.write_pattern_folder` writes any frames, and a pattern
folder's manifest serves ``hdrfringe import`` as the description (docs/import.md). Here the
played PNGs themselves are the "camera images" (a camera that sees the projector pixel for
pixel), so the rendered stripes and fringes are checked against written-out formulas and the
folder imported from them must decode to the projector column ``x``.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import imageio.v3 as iio
import numpy as np

from hdrfringe.core.captures import ProjectorInfo
from hdrfringe.core.decode import decode_captures
from hdrfringe.core.frames import UniformFrame, opencv_graycode_frames
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.io.captures import read_capture_folder
from hdrfringe.io.importer import import_captures
from hdrfringe.io.pattern_folder import write_pattern_folder

W, H, PITCH, STRIPE = 64, 32, 16.0, 8.0
TWO_PI = 2 * np.pi


def test_graycode_shift_angles_and_offset_round_trip_through_import(tmp_path: Path) -> None:
    shifted = FringeSpec(
        "sinusoidal", 3, PITCH, imin=0, migl=255, shifts_deg=(-120, 0, 120), phase_offset_deg=-90
    )
    sine = FringeSpec("sinusoidal", 4, PITCH, imin=0, migl=255, phase_offset_deg=-90)
    frames = [
        *shifted.frames(),
        *sine.frames(),
        *opencv_graycode_frames(W, H, STRIPE),
        UniformFrame(255.0),
        UniformFrame(0.0),
    ]
    played = write_pattern_folder(tmp_path / "pat", frames, ProjectorInfo(W, H, 8))
    assert played["version"] == 3  # shift angles, offsets and Gray code need version 3
    entries = played["frames"]
    assert (entries[0]["shift_deg"], entries[0]["phase_offset_deg"]) == (-120, -90)
    assert json.loads((tmp_path / "pat" / "manifest.json").read_text()) == played

    x = np.arange(W, dtype=float)
    # the first frame is cos(2*pi*x/p - 90 deg - 120 deg), written out
    first = iio.imread(tmp_path / "pat" / entries[0]["file"])
    ref = np.rint(255 * (1 + np.cos(TWO_PI * x / PITCH - np.radians(210))) / 2)
    np.testing.assert_array_equal(first, np.broadcast_to(ref, (H, W)))
    # OpenCV's sequence: the first image is the most significant column bit (bit 2 of 3)
    gray = iio.imread(tmp_path / "pat" / entries[7]["file"])
    m = np.floor(x / STRIPE).astype(int)
    lit = ((m ^ (m >> 1)) >> 2) & 1 == 1
    assert (entries[7]["bit"], entries[7]["inverse"]) == (2, False)
    np.testing.assert_array_equal(gray, np.broadcast_to(np.where(lit, 255, 0), (H, W)))

    cam = tmp_path / "cam"
    cam.mkdir()
    for i, e in enumerate(entries):  # k-th camera image in natural order = k-th frame played
        shutil.copy(tmp_path / "pat" / e["file"], cam / f"cam{i}.png")
    rep = import_captures(cam, tmp_path / "pat" / "manifest.json", tmp_path / "caps", bit_depth=8)
    assert rep.manifest["version"] == 3
    caps = read_capture_folder(tmp_path / "caps")
    assert caps.frames == frames  # every field survives: angles, offsets, bits, inverses
    assert len(caps.graycode_sets()) == 2

    dec = decode_captures(caps, min_modulation=0.0)
    for label, res in dec.set_results.items():  # both sets decode to 2*pi*x/p (mod 2*pi)
        err = np.angle(np.exp(1j * (res.wrapped_phase - TWO_PI * x / PITCH)))
        assert np.nanmax(np.abs(err)) < 0.01, label  # 8-bit rounding of the patterns
        assert np.isfinite(res.wrapped_phase).mean() > 0.7, label  # not vacuous (255 clips)
    (family,) = dec.families
    assert family.unwrapping == "graycode"
    absolute = family.absolute_phase
    assert absolute is not None and np.isfinite(absolute).mean() > 0.9
    np.testing.assert_allclose(
        absolute[np.isfinite(absolute)],
        np.broadcast_to(TWO_PI * x / PITCH, (H, W))[np.isfinite(absolute)],
        atol=0.01,
    )  # the Gray code fixed the fringe order of every pixel: no 2*pi jumps
