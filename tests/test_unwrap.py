"""Tests of hdrfringe.core.unwrap: spatial, temporal, centerline and absolute phase."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from hdrfringe.core.unwrap import (
    TemporalUnwrapResult,
    absolute_phase,
    absolute_phase_from_centerline,
    centerline_phase,
    detect_centerline,
    unwrap_spatial,
    unwrap_temporal,
    unwrap_temporal_levels,
)
from hdrfringe.errors import InputError

TWO_PI = 2.0 * np.pi
H, W = 494, 648  # camera image size used throughout (rows, columns)


def wrap(phase: np.ndarray) -> np.ndarray:
    return np.mod(phase, TWO_PI)


def orders(result: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """(result - truth) / 2pi at finite pixels, checked to be integers."""
    k = (result - truth) / TWO_PI
    k = k[np.isfinite(k)]
    assert np.allclose(k, np.rint(k), atol=1e-6), "result is not congruent to the truth"
    return np.unique(np.rint(k))


@pytest.fixture(scope="module")
def grid() -> tuple[np.ndarray, np.ndarray]:
    yy, xx = np.mgrid[0:H, 0:W].astype(np.float64)
    return yy, xx


@pytest.fixture(scope="module")
def surface(grid) -> np.ndarray:
    """Tilted plane plus two smooth bumps and noise: ~120 wraps, neighbour steps < pi."""
    yy, xx = grid
    rng = np.random.default_rng(11)
    truth = 1.1 * xx + 0.45 * yy
    truth += 9.0 * np.exp(-((xx - 250) ** 2 + (yy - 200) ** 2) / (2 * 45.0**2))
    truth -= 6.0 * np.exp(-((xx - 480) ** 2 + (yy - 330) ** 2) / (2 * 30.0**2))
    return truth + rng.normal(0.0, 0.15, truth.shape)


# ------------------------------------------------------------------------------------------
# Spatial unwrapping
# ------------------------------------------------------------------------------------------


class TestUnwrapSpatial:
    def test_noisy_tilted_plane_with_bumps(self, surface):
        out = unwrap_spatial(wrap(surface))
        assert out.dtype == np.float64 and out.shape == surface.shape
        assert np.isfinite(out).all()
        assert len(orders(out, surface)) == 1  # one constant 2*pi*k over the whole image
        assert 0.0 <= np.median(out) < TWO_PI  # anchoring rule: median in the first period
        k = (out - wrap(surface)) / TWO_PI  # exactly congruent to the input
        assert np.allclose(k, np.rint(k), atol=1e-9)

    def test_nan_holes_and_single_nan(self, surface):
        w = wrap(surface)
        w[100:160, 300:380] = np.nan
        w[400, 50] = np.nan
        w[0, 0] = np.nan
        out = unwrap_spatial(w)
        assert np.array_equal(np.isnan(out), np.isnan(w))
        assert len(orders(out, surface)) == 1

    def test_single_nan_does_not_hang(self):
        # scikit-image's unwrap_phase never returns on this input; ours must.
        yy, xx = np.mgrid[0:64, 0:64].astype(float)
        truth = 0.8 * xx + 0.3 * yy
        w = wrap(truth)
        w[20, 20] = np.nan
        out = unwrap_spatial(w)
        assert np.isnan(out[20, 20]) and np.isfinite(out).sum() == 64 * 64 - 1
        assert len(orders(out, truth)) == 1

    def test_inf_is_invalid(self):
        w = wrap(np.tile(np.linspace(0, 30, 50), (10, 1)))
        w[3, 3] = np.inf
        w[4, 4] = -np.inf
        out = unwrap_spatial(w)
        assert np.isnan(out[3, 3]) and np.isnan(out[4, 4])
        assert np.isfinite(out).sum() == w.size - 2

    def test_mask_respected(self, surface):
        mask = np.ones(surface.shape, bool)
        mask[200:260, :100] = False
        out = unwrap_spatial(wrap(surface), mask)
        assert np.isnan(out[~mask]).all() and np.isfinite(out[mask]).all()
        assert len(orders(out, surface)) == 1

    def test_garbage_under_mask_is_ignored(self, surface):
        mask = np.ones(surface.shape, bool)
        mask[250:253, :] = False  # a masked band splitting top from bottom
        w = wrap(surface)
        noisy = w.copy()
        noisy[~mask] = np.random.default_rng(0).uniform(0, TWO_PI, (~mask).sum())
        a = unwrap_spatial(w, mask)
        b = unwrap_spatial(noisy, mask)
        top, bottom = slice(0, 250), slice(253, None)
        for part in (top, bottom):
            assert len(orders(a[part], surface[part])) == 1
            assert len(orders(b[part], surface[part])) == 1

    def test_two_components_each_with_own_offset(self, surface):
        mask = np.ones(surface.shape, bool)
        mask[:, 320:324] = False  # splits the image into a left and a right part
        out = unwrap_spatial(wrap(surface), mask)
        left, right = out[:, :320], out[:, 324:]
        assert len(orders(left, surface[:, :320])) == 1
        assert len(orders(right, surface[:, 324:])) == 1
        # Each part is anchored on its own: its median lies in [0, 2*pi).
        assert 0.0 <= np.median(left) < TWO_PI
        assert 0.0 <= np.median(right) < TWO_PI
        # The true offset between the parts (many fringes) is not observable spatially.
        k_left = orders(left, surface[:, :320])[0]
        k_right = orders(right, surface[:, 324:])[0]
        assert k_left != k_right

    def test_corner_touching_regions_are_separate(self):
        w = np.full((4, 4), np.nan)
        w[:2, :2] = 1.0
        w[2:, 2:] = 5.0
        out = unwrap_spatial(w)
        assert np.allclose(out[:2, :2], 1.0) and np.allclose(out[2:, 2:], 5.0)

    def test_reference_pixel(self, surface):
        w = wrap(surface)
        out = unwrap_spatial(w, reference=(10, 600))
        assert out[10, 600] == pytest.approx(w[10, 600])
        assert len(orders(out, surface)) == 1
        out = unwrap_spatial(w, reference=(10, 600), reference_value=100.0)
        assert 100.0 - np.pi <= out[10, 600] < 100.0 + np.pi
        assert len(orders(out, surface)) == 1

    def test_reference_only_affects_its_component(self, surface):
        mask = np.ones(surface.shape, bool)
        mask[:, 320:324] = False
        out = unwrap_spatial(wrap(surface), mask, reference=(5, 600), reference_value=500.0)
        assert abs(out[5, 600] - 500.0) <= np.pi
        assert 0.0 <= np.median(out[:, :320]) < TWO_PI

    def test_reference_value_without_pixel_moves_medians(self, surface):
        out = unwrap_spatial(wrap(surface), reference_value=-40.0)
        assert -40.0 - np.pi <= np.median(out) < -40.0 + np.pi

    def test_min_component_size(self):
        w = wrap(np.tile(np.linspace(0, 20, 40), (20, 1)))
        mask = np.ones(w.shape, bool)
        mask[:, 30] = False
        mask[5, 31:] = False
        mask[4, 31:] = False  # leaves an island of rows 0..3 x cols 31..39 (36 px)
        out = unwrap_spatial(w, mask, min_component_size=37)
        assert np.isnan(out[:4, 31:]).all()
        assert np.isfinite(out[:, :30]).all()
        with pytest.raises(InputError, match="min_component_size"):
            unwrap_spatial(w, min_component_size=0)

    def test_deterministic(self, surface):
        w = wrap(surface)
        w[50:60, 50:400] = np.nan
        assert np.array_equal(unwrap_spatial(w), unwrap_spatial(w), equal_nan=True)

    def test_all_nan_and_empty_mask_give_nan(self):
        out = unwrap_spatial(np.full((30, 40), np.nan))
        assert out.shape == (30, 40) and np.isnan(out).all()
        out = unwrap_spatial(np.ones((30, 40)), np.zeros((30, 40), bool))
        assert np.isnan(out).all()

    def test_single_pixel(self):
        assert unwrap_spatial(np.array([[1.5]]))[0, 0] == 1.5
        w = np.full((5, 5), np.nan)
        w[2, 3] = 4.0
        out = unwrap_spatial(w)
        assert out[2, 3] == 4.0 and np.isnan(out).sum() == 24

    def test_single_row_and_column(self):
        truth = np.linspace(0, 50, 120)
        out = unwrap_spatial(wrap(truth)[None, :])
        assert len(orders(out[0], truth)) == 1
        out = unwrap_spatial(wrap(truth)[:, None])
        assert len(orders(out[:, 0], truth)) == 1

    def test_values_outside_first_period_accepted(self):
        truth = np.tile(np.linspace(0, 30, 60), (8, 1))
        centred = np.angle(np.exp(1j * truth))  # in (-pi, pi]
        out = unwrap_spatial(centred)
        assert len(orders(out, truth)) == 1
        k = (out - centred) / TWO_PI
        assert np.allclose(k, np.rint(k))

    @pytest.mark.parametrize(
        ("wrapped", "mask", "match"),
        [
            (np.zeros(5), None, "2-D"),
            (np.zeros((2, 2, 2)), None, "2-D"),
            (np.zeros((0, 4)), None, "empty"),
            (np.zeros((4, 4)), np.ones((4, 5), bool), "shape"),
            (np.zeros((4, 4)), np.ones((4, 4), np.uint8), "boolean"),
            (np.array([["a", "b"]]), None, "real"),
        ],
    )
    def test_bad_inputs(self, wrapped, mask, match):
        with pytest.raises(InputError, match=match):
            unwrap_spatial(wrapped, mask)

    def test_bad_reference(self):
        w = np.zeros((4, 4))
        w[1, 1] = np.nan
        with pytest.raises(InputError, match="outside"):
            unwrap_spatial(w, reference=(4, 0))
        with pytest.raises(InputError, match="invalid"):
            unwrap_spatial(w, reference=(1, 1))
        with pytest.raises(InputError, match="finite"):
            unwrap_spatial(w, reference_value=np.nan)

    @settings(max_examples=60, deadline=None)
    @given(
        shape=st.tuples(st.integers(2, 40), st.integers(2, 40)),
        slopes=st.tuples(st.floats(-2.0, 2.0), st.floats(-2.0, 2.0)),
        amp=st.floats(0.0, 3.0),
        freq=st.tuples(st.floats(0.0, 0.3), st.floats(0.0, 0.3)),
        offset=st.floats(-200.0, 200.0),
    )
    def test_property_smooth_field_recovered_up_to_2pik(self, shape, slopes, amp, freq, offset):
        # Neighbour steps: |slope| + amp*freq <= 2 + 0.9 < pi along either axis.
        yy, xx = np.mgrid[0 : shape[0], 0 : shape[1]].astype(float)
        truth = slopes[0] * xx + slopes[1] * yy + amp * np.sin(freq[0] * xx + freq[1] * yy)
        truth += offset
        out = unwrap_spatial(wrap(truth))
        assert np.isfinite(out).all()
        assert len(orders(out, truth)) == 1

    @settings(max_examples=40, deadline=None)
    @given(seed=st.integers(0, 2**32 - 1), density=st.floats(0.3, 0.95))
    def test_property_random_mask_each_component_constant(self, seed, density):
        rng = np.random.default_rng(seed)
        yy, xx = np.mgrid[0:30, 0:35].astype(float)
        truth = 1.7 * xx - 0.9 * yy + rng.uniform(-50, 50)
        mask = rng.random(truth.shape) < density
        out = unwrap_spatial(wrap(truth), mask)
        assert np.array_equal(np.isfinite(out), mask)
        labels, n = ndimage.label(mask)
        for i in range(1, n + 1):
            part = labels == i
            assert len(orders(out[part], truth[part])) == 1
            assert 0.0 <= np.median(out[part]) < TWO_PI


# ------------------------------------------------------------------------------------------
# Temporal unwrapping
# ------------------------------------------------------------------------------------------


def projector_x(grid) -> np.ndarray:
    """Projector column seen by each camera pixel: 50..~1000 px, bent by a surface."""
    yy, xx = grid
    return (
        60.0
        + 1.4 * xx
        + 25.0 * np.sin(yy / 50.0)
        + 15.0 * np.exp(-((xx - 300) ** 2 + (yy - 250) ** 2) / 5000.0)
    )


class TestUnwrapTemporal:
    def test_three_frequencies_noisy(self, grid):
        x = projector_x(grid)
        rng = np.random.default_rng(5)
        pitches = [1024.0, 256.0, 64.0]
        phis = [wrap(TWO_PI * x / p + rng.normal(0.0, 0.08, x.shape)) for p in pitches]
        out = unwrap_temporal(phis, pitches)
        truth = TWO_PI * x / 64.0
        correct = np.abs(out - truth) < np.pi  # an order error costs >= 2*pi
        assert correct.mean() >= 0.999
        # Where the order is right the result is the noisy fine phase itself (exactly).
        k = (out - phis[-1]) / TWO_PI
        assert np.allclose(k, np.rint(k), atol=1e-9)

    def test_non_integer_pitch_ratios(self, grid):
        x = projector_x(grid)
        rng = np.random.default_rng(6)
        pitches = [1100.0, 173.3, 29.7, 7.25]
        phis = [wrap(TWO_PI * x / p + rng.normal(0.0, 0.04, x.shape)) for p in pitches]
        result = unwrap_temporal_levels(phis, pitches)
        assert isinstance(result, TemporalUnwrapResult)
        assert len(result.levels) == 4 and len(result.level_residuals) == 3
        assert result.levels[-1] is result.phase
        for level, p in zip(result.levels, pitches, strict=True):
            assert (np.abs(level - TWO_PI * x / p) < np.pi).mean() >= 0.999
        assert result.residual.shape == x.shape
        assert np.nanmax(result.residual) <= np.pi + 1e-9

    def test_noise_free_is_exact(self):
        x = np.linspace(1.0, 1000.0, 5000)
        pitches = [1024.0, 100.0, 12.5]
        phis = [wrap(TWO_PI * x / p) for p in pitches]
        out = unwrap_temporal(phis, pitches)
        assert np.allclose(out, TWO_PI * x / 12.5, atol=1e-9)

    def test_coarse_already_unwrapped(self):
        x = np.linspace(0.0, 3000.0, 4001)  # wider than the coarse pitch
        pitches = [512.0, 64.0, 16.0]
        coarse = TWO_PI * x / 512.0
        phis = [coarse, wrap(TWO_PI * x / 64.0), wrap(TWO_PI * x / 16.0)]
        out = unwrap_temporal(phis, pitches, coarse_unwrapped=True)
        assert np.allclose(out, TWO_PI * x / 16.0, atol=1e-8)
        wrong = unwrap_temporal(phis, pitches)  # mod 2*pi: loses the coarse orders
        assert not np.allclose(wrong, TWO_PI * x / 16.0)

    def test_nan_propagates(self):
        x = np.linspace(10, 900, 100).reshape(10, 10)
        pitches = [1000.0, 100.0, 10.0]
        phis = [wrap(TWO_PI * x / p) for p in pitches]
        phis[0][0, 0] = np.nan
        phis[1][1, 1] = np.nan
        phis[2][2, 2] = np.inf
        r = unwrap_temporal_levels(phis, pitches)
        assert np.isnan(r.phase[0, 0]) and np.isnan(r.phase[1, 1]) and np.isnan(r.phase[2, 2])
        assert np.isnan(r.levels[1][0, 0]) and np.isfinite(r.levels[1][2, 2])
        assert np.isfinite(r.phase).sum() == 97
        assert np.isnan(r.residual[0, 0])

    def test_residual_threshold_flags_unreliable(self):
        x = np.linspace(10, 900, 400)
        pitches = [1000.0, 100.0]
        phis = [wrap(TWO_PI * x / p) for p in pitches]
        phis[0][:50] += 0.28  # scaled by 10: 2.8 rad off at the fine level, still rounds right
        r = unwrap_temporal_levels(phis, pitches)
        assert np.all(r.residual[:50] > 2.5) and np.all(r.residual[50:] < 1e-6)
        out = unwrap_temporal(phis, pitches, max_residual=1.0)
        assert np.isnan(out[:50]).all() and np.isfinite(out[50:]).all()

    def test_single_level(self):
        phi = np.array([[-0.5, 7.0, 1.0]])
        r = unwrap_temporal_levels([phi], [64.0])
        assert np.allclose(r.phase, np.mod(phi, TWO_PI))
        assert np.array_equal(r.residual, np.zeros_like(phi))

    @pytest.mark.parametrize(
        ("phases", "pitches", "match"),
        [
            ([np.zeros((4, 4)), np.zeros((4, 5))], [64.0, 8.0], "shape"),
            ([np.zeros((4, 4)), np.zeros((4, 4))], [8.0, 64.0], "strictly decreasing"),
            ([np.zeros((4, 4)), np.zeros((4, 4))], [64.0, 64.0], "strictly decreasing"),
            ([np.zeros((4, 4)), np.zeros((4, 4))], [64.0], "pitches"),
            ([], [], "at least one"),
            ([np.zeros(3), np.zeros(3)], [64.0, -8.0], "not positive"),
            ([np.zeros(3), np.zeros(3)], [np.inf, 8.0], "finite"),
        ],
    )
    def test_bad_inputs(self, phases, pitches, match):
        with pytest.raises(InputError, match=match):
            unwrap_temporal(phases, pitches)

    def test_bad_threshold(self):
        with pytest.raises(InputError, match="max_residual"):
            unwrap_temporal([np.zeros(3), np.zeros(3)], [64.0, 8.0], max_residual=4.0)


# ------------------------------------------------------------------------------------------
# Centerline detection
# ------------------------------------------------------------------------------------------


def gaussian_line(cols: np.ndarray, centre: np.ndarray, sigma: float, amp: float) -> np.ndarray:
    return amp * np.exp(-((cols - centre) ** 2) / (2.0 * sigma**2))


class TestDetectCenterline:
    @pytest.mark.parametrize("sigma", [0.8, 1.2, 2.0])
    @pytest.mark.parametrize("method", ["gaussian", "halfmax"])
    def test_subpixel_noise_free(self, sigma, method):
        centres = 200.0 + np.linspace(0.0, 1.0, 41)  # one row per sub-pixel offset
        cols = np.arange(W, dtype=float)[None, :]
        image = 12.0 + gaussian_line(cols, centres[:, None], sigma, 180.0)
        found = detect_centerline(image, method=method)
        assert np.max(np.abs(found - centres)) < 0.05
        if method == "gaussian":
            assert np.max(np.abs(found - centres)) < 1e-9  # exact for a Gaussian profile

    def test_horizontal_is_transpose(self):
        centres = 150.0 + np.linspace(0.0, 1.0, 60)
        rows = np.arange(H, dtype=float)[:, None]
        image = 5.0 + gaussian_line(rows, centres[None, :], 1.1, 100.0)
        found = detect_centerline(image, "horizontal")
        assert found.shape == (60,)
        assert np.max(np.abs(found - centres)) < 1e-9
        assert np.array_equal(found, detect_centerline(image.T, "vertical"))

    @pytest.mark.parametrize("method", ["gaussian", "halfmax"])
    def test_noise_and_ambient_light(self, grid, method):
        # Documented tolerance: at a peak SNR of 100 (amplitude 200 DN, noise 2 DN) on an
        # ambient gradient, rms error < 0.05 px and every row within 0.2 px.
        _, xx = grid
        rng = np.random.default_rng(3)
        centres = 300.37 + 0.05 * np.arange(H)
        image = 20.0 + 0.05 * xx + gaussian_line(xx, centres[:, None], 1.2, 200.0)
        image = np.round(image + rng.normal(0.0, 2.0, image.shape))
        found = detect_centerline(image, method=method)
        err = found - centres
        assert np.isfinite(found).all()
        assert np.sqrt(np.mean(err**2)) < 0.05
        assert np.max(np.abs(err)) < 0.2

    def test_saturated_plateau(self, grid):
        _, xx = grid
        rng = np.random.default_rng(4)
        centres = 280.21 + 0.031 * np.arange(H)
        image = 20.0 + gaussian_line(xx, centres[:, None], 1.5, 900.0)
        image = np.minimum(np.round(image + rng.normal(0.0, 2.0, image.shape)), 255)
        found = detect_centerline(image.astype(np.uint8))
        err = found - centres
        assert np.isfinite(found).all()
        assert np.sqrt(np.mean(err**2)) < 0.1 and np.max(np.abs(err)) < 0.3

    def test_no_line_gives_nan(self):
        rng = np.random.default_rng(8)
        assert np.isnan(detect_centerline(rng.normal(30.0, 3.0, (H, W)))).all()
        assert np.isnan(detect_centerline(np.full((10, 20), 7.0))).all()
        assert np.isnan(detect_centerline(np.full((10, 20), np.nan))).all()

    def test_min_contrast_mask_and_edges(self):
        cols = np.arange(50, dtype=float)
        image = np.tile(3.0 + gaussian_line(cols, 20.3, 1.0, 40.0), (6, 1))
        image[4] = 3.0 + gaussian_line(cols, 0.2, 1.0, 40.0)  # line at the image edge
        mask = np.ones(image.shape, bool)
        mask[1] = False
        mask[2, 21] = False  # the pixel next to the peak is masked
        found = detect_centerline(image, mask=mask)
        assert np.isnan(found[[1, 2, 4]]).all()
        assert np.allclose(found[[0, 3, 5]], 20.3, atol=1e-9)
        assert np.isnan(detect_centerline(image, min_contrast=50.0)).all()

    def test_bad_arguments(self):
        image = np.zeros((5, 5))
        with pytest.raises(InputError, match="orientation"):
            detect_centerline(image, "diagonal")
        with pytest.raises(InputError, match="method"):
            detect_centerline(image, method="peak")
        with pytest.raises(InputError, match=">= 0"):
            detect_centerline(image, min_snr=-1.0)
        with pytest.raises(InputError, match="2-D"):
            detect_centerline(np.zeros(5))


# ------------------------------------------------------------------------------------------
# Centerline phase and absolute phase
# ------------------------------------------------------------------------------------------


class TestCenterlinePhase:
    def test_linear_interpolation_and_mean(self):
        phase = np.tile(np.arange(10, dtype=float) * 0.5, (4, 1))
        pos = np.array([2.0, 3.5, np.nan, 8.25])
        assert centerline_phase(phase, pos) == pytest.approx(np.mean([1.0, 1.75, 4.125]))
        assert centerline_phase(phase, pos, statistic="median") == pytest.approx(1.75)

    def test_nan_phase_and_out_of_range_skipped(self):
        phase = np.tile(np.arange(10, dtype=float), (4, 1))
        phase[0, 3] = np.nan
        pos = np.array([2.5, 9.0, -1.0, 3.0])  # row 0 touches NaN, row 2 is outside
        assert centerline_phase(phase, pos) == pytest.approx(6.0)

    def test_horizontal(self):
        phase = np.tile(np.arange(8, dtype=float)[:, None], (1, 3))
        assert centerline_phase(phase, np.array([1.5, 2.5, 3.5]), "horizontal") == 2.5

    def test_errors(self):
        phase = np.zeros((4, 6))
        with pytest.raises(InputError, match="shape"):
            centerline_phase(phase, np.zeros(6))
        with pytest.raises(InputError, match="N_c = 0"):
            centerline_phase(phase, np.full(4, np.nan))
        with pytest.raises(InputError, match="statistic"):
            centerline_phase(phase, np.zeros(4), statistic="mode")


class TestAbsolutePhase:
    @pytest.mark.parametrize("k", [-23, -1, 0, 4, 117])
    @pytest.mark.parametrize("line_error", [-0.45, 0.0, 0.3])
    def test_round_recovers_contract_phase(self, grid, k, line_error):
        x = projector_x(grid)
        pitch, position = 24.0, 512.0
        truth = TWO_PI * x / pitch
        relative = truth + TWO_PI * k
        phi_c = TWO_PI * position / pitch + TWO_PI * k + line_error * np.pi  # < half a period
        out = absolute_phase(relative, phi_c, position, pitch)
        assert np.allclose(out, truth, atol=1e-9)

    def test_subtract_is_eq_2_13_plus_constant(self):
        relative = np.array([1.0, 2.0, np.nan])
        out = absolute_phase(relative, 0.7, 10.0, 8.0, method="subtract")
        assert np.allclose(out[:2], relative[:2] - 0.7 + TWO_PI * 10.0 / 8.0)
        assert np.isnan(out[2])

    def test_errors(self):
        with pytest.raises(InputError, match="method"):
            absolute_phase(np.zeros(3), 0.0, 1.0, 8.0, method="nearest")
        with pytest.raises(InputError, match="pitch"):
            absolute_phase(np.zeros(3), 0.0, 1.0, 0.0)
        with pytest.raises(InputError, match="phi_c"):
            absolute_phase(np.zeros(3), np.nan, 1.0, 8.0)

    def test_end_to_end_from_centerline_image(self, grid):
        """Wrapped phase -> spatial unwrap -> centerline -> absolute phase 2*pi*x/p."""
        yy, xx = grid
        rng = np.random.default_rng(9)
        x = projector_x(grid)
        pitch, position = 18.0, 512.0
        noisy = TWO_PI * x / pitch + rng.normal(0.0, 0.05, x.shape)
        wrapped = wrap(noisy)
        wrapped[:40, 500:560] = np.nan  # a hole, some of it on the line's rows
        unwrapped = unwrap_spatial(wrapped)
        # Camera column where the projector column equals `position`, row by row.
        line_col = np.array([np.interp(position, x[r], xx[r]) for r in range(H)])
        image = 15.0 + 0.02 * yy + gaussian_line(xx, line_col[:, None], 1.0, 150.0)
        image += rng.normal(0.0, 2.0, image.shape)
        for method in ("round", "subtract"):
            out = absolute_phase_from_centerline(
                unwrapped, image, position, pitch, "vertical", method=method
            )
            err = out - TWO_PI * x / pitch
            valid = np.isfinite(wrapped)
            assert np.array_equal(np.isfinite(out), valid)
            assert (np.abs(err[valid]) < np.pi).all()
        # "round" keeps the phase's own accuracy: the error is only the phase noise.
        out = absolute_phase_from_centerline(unwrapped, image, position, pitch)
        assert np.allclose(out[valid], noisy[valid], atol=1e-9)

    def test_shape_mismatch(self):
        with pytest.raises(InputError, match="shape"):
            absolute_phase_from_centerline(np.zeros((4, 5)), np.zeros((5, 4)), 1.0, 8.0)


# --- islands: phase_regions ---------------------------------------------------------------------
def _ramp_phase(x: np.ndarray, pitch: float) -> np.ndarray:
    return np.mod(2 * np.pi * x / pitch, 2 * np.pi)


def test_phase_regions_cut_at_steps_not_at_steep_slopes() -> None:
    from hdrfringe.core.unwrap import phase_regions

    # a steep smooth surface: 1.2 rad per pixel (pitch 5 px per camera px), curved
    cols = np.arange(300.0)
    x = np.tile(cols + 0.002 * cols**2, (40, 1))
    steep = phase_regions([_ramp_phase(x, 5.0)])
    assert steep.significant == 1 and not steep.islands
    # the same surface with a step of 2.5 periods (phase jump pi) blurred over two pixels
    x2 = x.copy()
    x2[:, 150:] += 12.5
    x2[:, 150] -= 6.0  # a mixed pixel halfway
    r = phase_regions([_ramp_phase(x2, 5.0)])
    assert r.islands and r.significant == 2
    assert sum(r.sizes) == 40 * 300 and all(abs(v - 40 * 150) <= 40 * 3 for v in r.sizes)
    assert r.labels[0, 0] != r.labels[0, 299] and (r.labels > 0).all()


def test_phase_regions_use_every_pitch() -> None:
    """A step of exactly 3 periods of pitch 10 is invisible in that map, not in a pitch-7 map."""
    from hdrfringe.core.unwrap import phase_regions

    x = np.tile(np.arange(200.0) * 0.5, (30, 1))
    x[:, 100:] += 30.0
    one = phase_regions([_ramp_phase(x, 10.0)])
    both = phase_regions([_ramp_phase(x, 10.0), _ramp_phase(x, 7.0)])
    assert not one.islands and both.islands and both.significant == 2


def test_phase_regions_specks_nan_and_errors() -> None:
    from hdrfringe.core.unwrap import phase_regions

    x = np.tile(np.arange(100.0), (50, 1))
    phi = _ramp_phase(x, 20.0)
    phi[:, 40:42] = np.nan  # an unlit gap: two regions
    phi[10:13, 70:73] = np.nan  # a hole does not split
    speck = np.zeros((50, 100), bool)
    speck[:, :] = True
    r = phase_regions([phi], speck)
    assert r.significant == 2 and (r.labels[np.isnan(phi)] == 0).all()
    lone = phi.copy()
    lone[:, 95:] = np.nan
    lone[20, 97] = 1.0  # a single valid pixel: a speck, not an island
    s = phase_regions([lone])
    assert s.significant == 2 and len(s.sizes) == 3 and s.sizes[-1] == 1
    assert phase_regions([np.full((3, 3), np.nan)]).sizes == ()
    with pytest.raises(InputError):
        phase_regions([])
    with pytest.raises(InputError):
        phase_regions([phi, phi[:10]])
    with pytest.raises(InputError):
        phase_regions([phi], threshold=4.0)
