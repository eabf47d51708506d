"""The image budget with two pitches (issue 26: 8 images where a stereo calibration lets two
pitches suffice).

With a projector-camera calibration and the scene's depth range, ``adaptive --max-images``
orders its coarsest set from the geometry (no one-period set): the family 64/8 px takes 8
images. Where the full-MIGL probe's first shift clips (a highlight), its other shifts are
dimmed along the clipped pixels' epipolar segments over the depth range. Checked against the
rig's ground truth, closed forms and independent geometry (triangulation); the full-size
numbers come from ``benchmarks/bench_compare.py`` (docs/adaptive.md, "Budget").
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from scipy.ndimage import binary_dilation, uniform_filter
from scipy.optimize import minimize_scalar

import hdrfringe.strategies.adaptive as adaptive_module
from hdrfringe import pipeline
from hdrfringe.core._validation import saturation_count
from hdrfringe.core.captures import Captures
from hdrfringe.core.frames import ImageFrame
from hdrfringe.core.geometric_order import ray_coordinate_span, ray_projector_points
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.stereo import triangulate, triangulate_maps
from hdrfringe.core.uncertainty import NoiseModel
from hdrfringe.errors import CaptureFormatError, InputError
from hdrfringe.rig.factory import virtual_rig
from hdrfringe.strategies.adaptive import adaptive_sets
from hdrfringe.strategies.conventional import conventional
from hdrfringe.tasks.compare import DEPTH_RANGE_MM, SCENES

TWO_PI = 2 * np.pi
TWO = [FringeSpec("sinusoidal", 4, p) for p in (64.0, 8.0)]
#: Smaller sets where only the bookkeeping is checked (a tiny camera resolves 16 px).
TWO_SMALL = [FringeSpec("sinusoidal", 4, p) for p in (64.0, 16.0)]


@pytest.fixture(scope="module")
def specular() -> dict[str, Any]:
    """The specular part at the rig's 648 x 494 (an 8 px set is resolved there), noise seed 2,
    pitches 64 and 8 px, budget 8, the rig's own calibration and the compare rows' depth
    range; and the pixels a conventional 64 px set clips on a fresh rig of the same seed (the
    highlight, defined independently of the run)."""
    rig = virtual_rig("specular_part", seed=2)
    res = adaptive_sets(rig, TWO, max_images=8, depth_range_mm=DEPTH_RANGE_MM)
    fresh = virtual_rig("specular_part", seed=2)
    clipped = saturation_count(conventional(fresh, TWO[0]).images, fresh.camera_bit_depth) > 0
    truth = rig.truth()
    err = res[-1].absolute_phase - TWO_PI * truth.u / TWO[-1].pitch_px
    return {"res": res, "err": err, "valid": truth.valid, "highlight": truth.valid & clipped}


def test_two_pitches_measure_a_highlight_in_eight_images(specular: dict[str, Any]) -> None:
    """8 images: the probe (its first shift at the full MIGL, the others dimmed along the
    clipped pixels' epipolar segments) and one adapted set. Against the rig's truth: at least
    99.9 % of the valid pixels and 99 % of the highlight's have a phase, every one in order
    (largest error 0.21 rad measured; an 8 px order is 2 pi), the highlight's std within
    0.06 rad (32 mrad measured) and the field's within 10 % of that of the pixels more than
    8 px from the highlight (1.03x measured). Rejects the probe without its dimmed shifts (the
    highlight left to a guessed level: its std 87 mrad, the field 1.25x), the coarse phase
    averaged without the plane (a 64 px ramp averaged beside holes reads its centroid's
    phase: wrong orders, largest error 6.6 rad) and faint pixels left to order the 8 px set
    (:data:`~hdrfringe.strategies.adaptive.BUDGET_DIM_MIN_MODULATION` 0: 105 wrong orders).
    (The straddle rule, ``BUDGET_STRADDLE_PX``, is not what this test checks: without it the
    std here is 20.56 mrad against 20.38, no order changes; docs/adaptive.md "Budget".)"""
    res, err, valid, highlight = (specular[k] for k in ("res", "err", "valid", "highlight"))
    b = res[-1].details["budget"]
    assert sum(r.images_captured for r in res) == b["images"] == 8
    assert b["probe_dimmed"] and b["depth_range_mm"] == list(DEPTH_RANGE_MM)
    assert res[-1].details["mapping_pitches"] == {"vertical": [64.0]}  # no one-period set
    ok = valid & np.isfinite(err)
    assert highlight.sum() > 0.01 * valid.sum()
    assert ok.sum() >= 0.999 * valid.sum()
    assert (highlight & ok).sum() >= 0.99 * highlight.sum()
    assert np.abs(err[ok]).max() < np.pi / 4
    assert err[highlight & ok].std() < 0.06
    far = ok & ~binary_dilation(highlight, iterations=8)
    assert err[ok].std() <= 1.1 * err[far].std()
    # the probe's result carries the dimmed map of its shifts after the first
    dimmed = res[0].captured[0].migl_map
    assert dimmed is not None and dimmed.min() == adaptive_module.BUDGET_SAFE_MIGL
    assert np.median(dimmed) == 255.0


@pytest.mark.parametrize(
    ("specs", "budget", "depth"),
    [
        ([FringeSpec("sinusoidal", 4, p) for p in (1024.0, 64.0, 16.0)], 12, None),
        (TWO_SMALL, 8, DEPTH_RANGE_MM),
    ],
    ids=["three-pitches", "two-pitches"],
)
def test_nothing_saturated_is_conventional_with_or_without_a_depth_range(
    specs: list[FringeSpec], budget: int, depth: tuple[float, float] | None
) -> None:
    """Requirement 4 with the depth range too: a dim plate that clips nowhere gets the
    conventional sets bit for bit, in the conventional number of images, and no absolute
    phase of the strategy's own (the measurement orders it as any conventional family).
    Rejects a probe dimmed or completed where nothing clipped."""
    kw: dict[str, Any] = {"resolution": (64, 48), "seed": 3}
    conv = [conventional(virtual_rig("white_plate", **kw), s) for s in specs]  # 16 px: 64 x 48
    assert not any(c.never_unsaturated.any() for c in conv)
    res = adaptive_sets(
        virtual_rig("white_plate", **kw), specs, max_images=budget, depth_range_mm=depth
    )
    assert sum(r.images_captured for r in res) == budget
    for got, want in zip(res, conv, strict=True):
        assert np.array_equal(got.images, want.images) and got.absolute_phase is None
    assert res[-1].details["budget"]["conventional"] is True


def test_the_depth_range_holds_the_scenes_with_one_order() -> None:
    """The compare rows' depth range (:data:`~hdrfringe.tasks.compare.DEPTH_RANGE_MM`): the
    four scenes' surfaces (triangulated from the rig's true projector columns) lie inside it,
    and over it every pixel's ray moves less than a 64 px pitch less the geometric order's
    margins in the projector (one candidate order: 42.3 px at most against 48). Rejects a
    range that misses the glossy dome's top (1870 mm) or one deep enough for two orders
    (1850:1930: 55.9 px)."""
    for name, options in SCENES.items():
        rig = virtual_rig(resolution=(162, 123), seed=0, **options)
        calib, truth = rig.stereo_calibration(), rig.truth()
        depth = triangulate_maps(calib, u_proj=np.where(truth.valid, truth.u, np.nan)).depth_mm
        z = depth[np.isfinite(depth)]
        assert DEPTH_RANGE_MM[0] < z.min() and z.max() < DEPTH_RANGE_MM[1], name
        lo, hi = ray_coordinate_span(calib, "vertical", DEPTH_RANGE_MM)
        span = (hi - lo)[truth.valid]
        assert np.nanmax(span) < 64.0 * (1 - 2 * 0.125), name


def test_the_segment_points_lie_on_the_ray_over_the_depth_range() -> None:
    """:func:`~hdrfringe.core.geometric_order.ray_projector_points`: triangulating each point
    back with the camera pixel (its projector column alone, :func:`triangulate`) gives depths
    from ``zmin`` to ``zmax``, evenly spaced in ``1/z``; consecutive points at most
    ``step_px`` apart; the columns' range is :func:`ray_coordinate_span`'s."""
    rig = virtual_rig("white_plate", resolution=(162, 123), seed=0)
    calib = rig.stereo_calibration()
    cols, rows = np.array([10.0, 80.0, 150.0]), np.array([5.0, 60.0, 118.0])
    u, v = ray_projector_points(calib, DEPTH_RANGE_MM, cols, rows, step_px=0.5)
    assert u.shape[0] >= 3 and np.isfinite(u).all() and np.isfinite(v).all()
    assert np.hypot(np.diff(u, axis=0), np.diff(v, axis=0)).max() <= 0.5 + 1e-9
    for j in range(cols.size):
        back = triangulate(calib, np.full(u.shape[0], cols[j]), np.full(u.shape[0], rows[j]),
                           u_proj=u[:, j])  # fmt: skip
        inverse = 1.0 / back.xyz[:, 2]
        want = np.linspace(1.0 / DEPTH_RANGE_MM[0], 1.0 / DEPTH_RANGE_MM[1], u.shape[0])
        np.testing.assert_allclose(inverse, want, rtol=1e-9)
    lo, hi = ray_coordinate_span(calib, "vertical", DEPTH_RANGE_MM, u_cam=cols, v_cam=rows)
    np.testing.assert_allclose(u.min(axis=0), lo, atol=1e-6)
    np.testing.assert_allclose(u.max(axis=0), hi, atol=1e-6)


def test_the_plane_mean_is_unbiased_on_a_ramp_beside_holes() -> None:
    """A ramp of 0.16 rad per pixel (a 64 px fringe at 648 x 494) with holes and an edge: the
    plane mean gives the ramp back to rounding, NaN stays NaN, and noise shrinks with the
    window, also on the image's border. Rejects the plain mean (the centroid's value: up to
    0.62 rad off beside this hole) and a window that repeats the border's pixels."""
    rows, cols = np.mgrid[0:60, 0:80].astype(float)
    ramp = 0.16 * cols + 0.03 * rows
    holed = ramp.copy()
    holed[20:30, 30:45] = np.nan
    holed[:, :3] = np.nan
    got = adaptive_module._plane_mean(holed, 15)
    ok = np.isfinite(holed)
    assert np.array_equal(np.isfinite(got), ok)
    assert np.abs(got - ramp)[ok].max() < 1e-9
    # the plain mean over the same window: the centroid's value beside the holes
    mean = uniform_filter(np.where(ok, holed, 0.0), 15) / uniform_filter(ok.astype(float), 15)
    assert np.abs(mean - ramp)[ok].max() > 0.5
    noisy = holed + np.random.default_rng(0).normal(0.0, 0.2, ramp.shape)
    d = (adaptive_module._plane_mean(noisy, 15) - ramp)[ok]
    assert d.std() < 0.2 / 5
    # the image's border: its window holds only real pixels (0.040 rad on the top row; the
    # edge repeated into the window, 0.146: the border pixel weighs itself many times over)
    full = ramp + np.random.default_rng(0).normal(0.0, 0.2, ramp.shape)
    assert (adaptive_module._plane_mean(full, 15) - ramp)[0].std() < 0.2 / 4


def test_the_exposure_weighs_the_shot_noise() -> None:
    """With the camera's noise (read 1 DN, 0.0128 DN per electron: the virtual rig's), the
    exposure minimises the mean ``sigma^2(I) / modulation^2`` (against its two-class closed
    form, minimised by scipy), with ``I`` the pixel's mean intensity at that exposure; a
    MIGL-limited bright half then holds it shorter than the read noise alone does (its mean
    intensity, hence its shot noise, stays at the top while its modulation falls). Rejects
    the noise left out (the longer choice) and the variance at the reference exposure's
    intensity."""
    shape = (40, 50)
    gain = np.full(shape, 0.1)
    gain[:, :25] = 1.2
    ambient = np.full(shape, 2.0)
    mp = adaptive_module._Mapping({}, {}, {}, {}, {}, gain, ambient, np.zeros(shape, bool))
    first = FringeSpec("sinusoidal", 4, 16.0)
    noise = NoiseModel(1.0, 0.0128)
    top = 0.985 * 255

    def choose(model: NoiseModel | None) -> float:
        return adaptive_module._exposure_from_mapping(mp, first, 8, 0.015, 10.0, model) / 10.0

    def variance(s: float) -> float:
        out = []
        for g in (0.1, 1.2):
            m = min(255.0, (top / s - 2.0) / g)
            mod = s * g * (m - 40.0) / 2.0
            out.append(noise.variance(s * (2.0 + g * (m + 40.0) / 2.0)) / mod**2)
        return float(np.mean(out))

    s_max = min(top / (1.2 * 60 + 2), 53.03 / 10.75)  # the bright half above the floor, cap
    best = minimize_scalar(variance, bounds=(1 / 16, s_max), method="bounded").x
    got = choose(noise)
    assert abs(np.log2(got / best)) <= 1 / 16 + 1e-3
    assert got < choose(None)


def test_the_noise_comes_from_the_mapping_residuals_without_the_completed_pixels() -> None:
    """The camera noise for the exposure is estimated from the mapping sets' 4-step residuals
    (:func:`~hdrfringe.core.uncertainty.estimate_noise`), leaving out the pixels whose first
    shift was completed from the other three (no residual: an estimate with them reads low);
    with no residual at all, the rig's own description (the virtual rig's noise model).
    Rejects the completed pixels kept (0.6x the noise here) and no fallback (None)."""
    rng = np.random.default_rng(0)
    spec = FringeSpec("sinusoidal", 4, 64.0)
    x = np.tile(np.arange(96.0), (64, 1))
    clean = np.stack([100 + 60 * np.cos(TWO_PI * x / 64 - k * np.pi / 2) for k in range(4)])
    shots = np.clip(np.rint(clean + rng.normal(0.0, 2.0, clean.shape)), 0, 255).astype(np.uint8)
    completed = np.zeros(x.shape, bool)
    completed[:, :64] = True  # two thirds of the field completed from three shifts
    shots[0, completed] = adaptive_module._with_first_shift(shots[1:], 8)[0, completed]
    mp = adaptive_module._Mapping(
        {"vertical": [64.0]}, {"vertical": [shots]}, {}, {}, {}, np.ones(x.shape),
        np.zeros(x.shape), np.zeros(x.shape, bool),
    )  # fmt: skip
    rig = virtual_rig("white_plate", resolution=(96, 64), seed=0)
    got = adaptive_module._mapping_noise(rig, mp, spec, 8, completed)
    assert got is not None and got.sigma(100.0) == pytest.approx(2.0, rel=0.15)
    kept = adaptive_module._mapping_noise(rig, mp, spec, 8, None)
    assert kept is not None and kept.sigma(100.0) < 0.8 * got.sigma(100.0)
    fallback = adaptive_module._mapping_noise(rig, mp, spec, 8, np.ones(x.shape, bool))
    assert fallback is not None and fallback.read_dn == pytest.approx(
        rig.camera_manifest()["read_noise_dn"]
    )


def test_a_depth_range_is_refused_where_it_cannot_order() -> None:
    """A depth range without a budget, or without a calibration (horizontal sets: the budget
    maps both ladders), is refused with one line; the budget's minimum names the option; a
    range that orders (almost) no pixel says so, with what went wrong (before: "no camera
    pixel was mapped to the projector")."""
    rig = virtual_rig("white_plate", resolution=(64, 48), seed=0)
    with pytest.raises(InputError, match="give max_images"):
        adaptive_sets(rig, TWO_SMALL, depth_range_mm=DEPTH_RANGE_MM)
    rows = [FringeSpec("sinusoidal", 4, p, "horizontal") for p in (64.0, 16.0)]
    with pytest.raises(InputError, match="projector-camera calibration"):
        adaptive_sets(rig, rows, max_images=8, depth_range_mm=DEPTH_RANGE_MM)
    with pytest.raises(InputError, match="--depth-range"):
        adaptive_sets(rig, TWO_SMALL, max_images=8)
    with pytest.raises(InputError, match="depth range"):
        adaptive_sets(rig, TWO_SMALL, max_images=8, depth_range_mm=(1900.0, 1850.0))
    # a range the plate (1900 mm) lies outside, or one too deep for a 64 px order: the range
    # is named, not the mapping (which decoded)
    spec = [FringeSpec("sinusoidal", 4, p) for p in (64.0, 16.0)]
    for far, why in (((500.0, 600.0), "100 % without one"), ((1500.0, 2500.0), "ambiguous")):
        bright = virtual_rig("white_plate", resolution=(64, 48), seed=0, ambient_lux=600.0)
        with pytest.raises(InputError, match=f"depth range .* mm gives 0 %.*{why}"):
            adaptive_sets(bright, spec, max_images=8, depth_range_mm=far)


def test_a_recorded_run_without_complete_sets_needs_its_sets_named() -> None:
    """A folder whose shots form no fringe set (a two-pitch budget run records image frames
    only) replays with the sets its log names; without them it is refused with one line."""
    projector = virtual_rig("white_plate", resolution=(8, 6), seed=0).projector
    image = np.full((projector.height, projector.width), 10.0, np.float32)
    frames = [ImageFrame(image, f"shot_{k}") for k in range(4)]
    caps = Captures(frames, np.zeros((4, 6, 8), np.uint8), 8, projector=projector)
    with pytest.raises(CaptureFormatError, match="no fringe sets to run a strategy on"):
        pipeline.measure(caps, strategy="adaptive")
