"""The high-dynamic-range scene ``specular_part``: its dynamic range, exact heights, highlight.

Broken variants each test rejects are named in the docstrings.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from hdrfringe.core.frames import UniformFrame
from hdrfringe.errors import InputError
from hdrfringe.rig.factory import virtual_rig
from hdrfringe.rig.scenes import SpecularPart, make_scene, scene_from_manifest, specular_part
from hdrfringe.rig.simulated import SimulatedRig


def _part_pixels(rig: SimulatedRig) -> np.ndarray:
    assert isinstance(rig.scene, SpecularPart)
    tr = rig.truth()
    return rig.scene.on_part(tr.x_mm, tr.y_mm) & tr.valid


def _ratio_truth(rig: SimulatedRig) -> float:
    """Brightest valid ``S (r + k_s (n.h)^m)`` over the median ``S r`` of the part's pixels."""
    tr = rig.truth()
    part = _part_pixels(rig)
    lit = tr.shading * (tr.reflectivity + tr.specular)
    return float(lit[tr.valid].max() / np.median((tr.shading * tr.reflectivity)[part]))


def _ratio_signal(rig: SimulatedRig) -> float:
    """The same from the noise-free signal of a full-white frame (MIGL 255), over the rig
    with the lobe switched off for the diffuse level (camera blur included)."""
    tr = rig.truth()
    part = _part_pixels(rig)
    white = [UniformFrame(255.0)]
    lit = rig.expected_signal(white)[0] - rig.ambient_signal()
    assert isinstance(rig.scene, SpecularPart)
    matte = rig.replace(scene=dataclasses.replace(rig.scene, specular=0.0))
    diffuse = matte.expected_signal(white)[0] - matte.ambient_signal()
    return float(lit[tr.valid].max() / np.median(diffuse[part]))


@pytest.fixture(scope="module")
def small() -> SimulatedRig:
    return virtual_rig("specular_part", resolution=(160, 120))


def test_the_highlight_is_30_to_100_times_the_diffuse_level(small: SimulatedRig) -> None:
    """Measured: 48.8x (truth) and 46.9x (signal) at 160 x 120; 51.3x and 51.1x at the default
    648 x 494 (docs/virtual_rig.md). Rejects a lobe on the whole part (the median would carry
    it), a matte boss (ratio ~1) or a lobe scaled out of the 30..100 band."""
    assert 45.0 < _ratio_truth(small) < 52.0
    assert 43.0 < _ratio_signal(small) < 50.0
    full = virtual_rig("specular_part")
    assert 49.0 < _ratio_truth(full) < 53.0
    assert 49.0 < _ratio_signal(full) < 53.0
    # the bound is the lobe's, not an accident of the geometry: a tenth of the gain falls out
    weak = small.replace(scene=specular_part(specular=1.2))
    assert _ratio_truth(weak) < 10.0


def test_heights_are_exact_at_known_points() -> None:
    """Closed-form values written out by hand (block 8 mm, chamfer slope 1, boss radius 30 cut
    6 mm above the top, straight over |y| <= 40). Rejects a boss measured from the plane
    instead of the block top, a chamfer of another slope, a boss without its end caps."""
    part = specular_part()
    x = np.array([0.0, 12.0, 18.0, 50.0, 94.0, 98.5, 0.0, 0.0, 0.0, 150.0])
    y = np.array([0.0, 30.0, -20.0, 0.0, 0.0, 0.0, 50.0, 58.0, 69.0, 0.0])
    want = [
        14.0,  # crest
        8.0 + math.sqrt(900.0 - 144.0) - 24.0,  # cylinder flank
        8.0,  # boss edge: sqrt(900 - 324) = 24
        8.0,  # block top
        4.0,  # chamfer, 4 mm out
        0.0,  # past the chamfer foot (98)
        8.0 + math.sqrt(900.0 - 100.0) - 24.0,  # end cap, 10 mm past the straight part
        8.0,  # past the end cap (18 mm)
        4.0,  # chamfer along Y (65 + 4)
        0.0,  # the plane
    ]
    assert np.allclose(part.height(x, y), want, atol=1e-12)
    assert np.allclose(specular_part(base_mm=3.0).height(x, y), np.add(want, 3.0), atol=1e-12)


def test_the_rig_sees_the_formula_heights_and_the_analytic_gradient(small: SimulatedRig) -> None:
    """Traced heights equal the closed form at the traced points (an independent numpy
    expression), and the analytic gradient (used for shading and the lobe) matches central
    differences away from the kinks. Rejects a sign error in the boss or chamfer slopes."""
    tr = small.truth()
    x, y = tr.x_mm, tr.y_mm
    block = np.clip(8.0 - np.maximum(np.maximum(np.abs(x) - 90, np.abs(y) - 65), 0), 0, 8)
    rho2 = x**2 + np.maximum(np.abs(y) - 40, 0) ** 2
    boss = np.where(rho2 < 18.0**2, np.sqrt(np.maximum(900.0 - rho2, 0)) - 24.0, 0.0)
    assert np.allclose(tr.height_mm, block + np.maximum(boss, 0), atol=1e-6)
    assert tr.valid.all() and 13.5 < tr.height_mm.max() <= 14.0
    part = small.scene
    rng = np.random.default_rng(1)
    px, py = rng.uniform(-110, 110, 4000), rng.uniform(-80, 80, 4000)
    gx, gy = part.gradient(px, py)
    e = 1e-4
    nx = (part.height(px + e, py) - part.height(px - e, py)) / (2 * e)
    ny = (part.height(px, py + e) - part.height(px, py - e)) / (2 * e)
    smooth = (np.abs(nx - gx) < 0.5) & (np.abs(ny - gy) < 0.5)  # kinks: one-sided jumps
    assert smooth.mean() > 0.99
    assert np.allclose(gx[smooth], nx[smooth], atol=1e-4)
    assert np.allclose(gy[smooth], ny[smooth], atol=1e-4)
    assert np.abs(gx).max() > 0.5  # the boss and chamfers are there


def test_the_highlight_is_a_stripe_on_the_boss_on_the_projector_side(small: SimulatedRig) -> None:
    """The lobe peaks where the boss normal bisects the projector and camera directions, about
    30 sin(7.5 deg) = 3.9 mm from the crest toward the projector (-X); the matte block has
    none. Rejects a lobe on the block or a highlight on the wrong side."""
    tr = small.truth()
    assert not np.any(tr.specular[np.abs(tr.x_mm) > 18.5])
    peak = np.unravel_index(np.argmax(tr.specular), tr.specular.shape)
    assert -7.0 < tr.x_mm[peak] < -1.0
    rows = np.abs(tr.y_mm[:, 0]) < 35  # along the straight part, every row has its highlight
    assert np.all(tr.specular[rows].max(axis=1) > 0.5 * tr.specular.max())


def test_scene_parameters_are_checked_and_round_trip() -> None:
    part = specular_part(boss_mm=4.0, specular=20.0)
    assert scene_from_manifest(part.to_manifest()) == part
    assert isinstance(make_scene("specular_part"), SpecularPart)
    assert virtual_rig("specular_part", depth_mm=5.0).scene.to_manifest()["base_mm"] == 5.0
    with pytest.raises(InputError, match="does not fit on the block top"):
        specular_part(boss_radius_mm=200.0, boss_mm=10.0)
    with pytest.raises(InputError, match="boss_mm must be in"):
        specular_part(boss_mm=40.0)
    with pytest.raises(InputError, match="block_mm must be > 0"):
        specular_part(block_mm=0.0)
