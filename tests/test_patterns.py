"""Pattern convention of the capture-folder contract, gamma pre-compensation, frames."""

from __future__ import annotations

import numpy as np
import pytest

from hdrfringe.core.frames import (
    CenterlineFrame,
    FringeFrame,
    UniformFrame,
    frame_from_manifest,
    render_frame,
)
from hdrfringe.core.patterns import FringeSpec, fringe_gray, fringe_profile, precompensate_gamma
from hdrfringe.errors import InputError


def test_profiles_peak_at_zero_period_one() -> None:
    t = np.linspace(-2, 2, 801)
    for pat in ("sinusoidal", "triangular"):
        p = fringe_profile(t, pat)
        assert np.allclose(fringe_profile(t + 1, pat), p)
        assert fringe_profile(0.0, pat) == pytest.approx(1.0)
        assert fringe_profile(0.5, pat) == pytest.approx(-1.0)
        assert p.min() >= -1 - 1e-12 and p.max() <= 1 + 1e-12
    # the triangle is linear between its peak and trough
    assert fringe_profile(0.125, "triangular") == pytest.approx(0.5)


def test_gray_formula_matches_contract() -> None:
    spec = FringeSpec("sinusoidal", 4, 7.3, "vertical", 40, 200)
    x = np.linspace(0, 50, 333)
    for i in range(4):
        expect = 40 + 160 * (1 + np.cos(2 * np.pi * (x + i * 7.3 / 4) / 7.3)) / 2
        assert np.allclose(fringe_gray(x, spec, i), expect)


def test_precompensation_formula_and_rounding() -> None:
    g = np.arange(256)
    out = precompensate_gamma(g, 2.812, 8)
    assert out.dtype == np.uint8
    assert np.array_equal(out, np.rint(255 * (g / 255) ** (1 / 2.812)).astype(np.uint8))
    assert np.array_equal(precompensate_gamma(g, 1.0, 8), g)
    assert precompensate_gamma([65535.0], 2.0, 16).dtype == np.uint16


def test_render_orientation_and_size() -> None:
    spec = FringeSpec("triangular", 3, 6.5, "horizontal", 0, 255)
    img = render_frame(FringeFrame(spec, 1), 31, 17, 1.0, 8)
    assert img.shape == (17, 31)
    assert np.all(img == img[:, :1])  # horizontal fringes vary along rows only
    expect = np.rint(fringe_gray(np.arange(17), spec, 1)).astype(np.uint8)
    assert np.array_equal(img[:, 0], expect)
    line = render_frame(CenterlineFrame(10, "vertical", 200), 21, 5)
    assert np.array_equal(np.nonzero(line[0])[0], [10]) and line[0, 10] == 200
    assert np.all(render_frame(UniformFrame(77), 4, 3) == 77)


def test_manifest_round_trip() -> None:
    frames = [
        *FringeSpec("sinusoidal", 5, 9.25, "vertical", 40, 180).frames(),
        CenterlineFrame(512, "horizontal", 255),
        UniformFrame(128),
    ]
    for f in frames:
        assert frame_from_manifest(f.manifest_entry("x.png")) == f


@pytest.mark.parametrize(
    "kwargs",
    [
        {"pattern": "square"},
        {"steps": 2},
        {"pattern": "triangular", "steps": 1},
        {"pitch_px": 0},
        {"pitch_px": float("nan")},
        {"imin": 200, "migl": 100},
        {"orientation": "diagonal"},
    ],
)
def test_bad_specs_are_refused(kwargs: dict) -> None:
    with pytest.raises(InputError):
        FringeSpec(**kwargs)


def test_migl_above_projector_range_is_refused() -> None:
    with pytest.raises(InputError, match="exceeds"):
        render_frame(FringeFrame(FringeSpec(migl=300), 0), 8, 8, 1.0, 8)
