"""Predicted phase std (hdrfringe.core.uncertainty) against Monte Carlo runs of the decoders
themselves.

Every formula is checked against the std of the phase that the decoder under test returns for
many noisy draws of the same pixels (the decoders, not the predictor, make the reference). The
margins are 6 %: with 4000 draws per phase the sampling error of a std is about 1.1 %, and the
first-order propagation is exact to well under 1 % at these noise levels (sigma/b <= 0.05).
Each test also shows the broken predictor it rejects (sqrt(1/N) instead of sqrt(2/N), the mean
intensity instead of the modulation, one sigma instead of shot noise, the full set's gain for
a partial fit).
"""

from __future__ import annotations

import numpy as np
import pytest

from hdrfringe.core.patterns import FringeSpec, fringe_profile
from hdrfringe.core.phase import (
    decode_set,
    sinusoidal_phase,
    sinusoidal_phase_ls,
    triangular_2step,
    triangular_3step,
)
from hdrfringe.core.saturation.tolerant import tolerant_noise_gain, tolerant_phase
from hdrfringe.core.uncertainty import (
    NoiseModel,
    estimate_noise,
    fit_noise_model,
    height_derivative,
    noise_from_manifest,
    phase_std_least_squares,
    phase_std_sinusoidal,
    phase_std_triangular,
    predict_phase_std,
)
from hdrfringe.errors import InputError

DRAWS = 4000
TOL = 0.06


def _circular_std(phase: np.ndarray, axis: int = 0) -> np.ndarray:
    """Std of a wrapped phase about its circular mean (no wrap jumps)."""
    mean = np.angle(np.exp(1j * phase).mean(axis=axis, keepdims=True))
    return np.sqrt(np.mean(np.angle(np.exp(1j * (phase - mean))) ** 2, axis=axis))


def _noisy(clean: np.ndarray, noise: NoiseModel, seed: int) -> np.ndarray:
    """``DRAWS`` noisy copies of ``clean`` (N, P): shape (N, DRAWS, P), Gaussian, per the model."""
    rng = np.random.default_rng(seed)
    z = rng.standard_normal((clean.shape[0], DRAWS, clean.shape[1]))
    return clean[:, None, :] + noise.sigma(clean)[:, None, :] * z


PHASES = np.linspace(0.05, 2 * np.pi - 0.05, 13)


@pytest.mark.parametrize("steps", [3, 4, 8])
def test_sinusoidal_equal_shifts_with_shot_noise(steps: int) -> None:
    a, b = 120.0, 60.0
    noise = NoiseModel(1.5, 0.05)  # shot noise dominates at the bright shifts
    delta = 2 * np.pi * np.arange(steps) / steps
    clean = a + b * np.cos(PHASES[None, :] + delta[:, None])
    phi, _, _ = sinusoidal_phase(_noisy(clean, noise, steps))
    measured = _circular_std(phi)
    predicted = phase_std_least_squares(
        np.degrees(delta), PHASES, np.full(PHASES.shape, b), np.full(PHASES.shape, a), noise
    )
    ratio = measured / predicted
    assert np.all(np.abs(ratio - 1) < TOL), ratio
    # the textbook form with sigma_I at the mean intensity: exact for N != 3 (docs/uncertainty.md)
    textbook = phase_std_sinusoidal(b, noise.sigma(a), steps)
    if steps != 3:
        assert np.allclose(predicted, textbook, rtol=1e-12)
    else:  # N = 3: a cos(3 phi) term of the shot noise, up to +-11 % here
        assert 0.05 < np.ptp(predicted / textbook) < 0.3
    # broken predictors fail: sqrt(1/N) (off by 1/sqrt 2), the mean instead of the modulation
    assert np.all(np.abs(measured / (predicted / np.sqrt(2)) - 1) > TOL)
    assert np.all(np.abs(measured / (predicted * b / a) - 1) > TOL)


def test_shot_noise_matters_where_intensities_differ() -> None:
    """One sigma (the read noise alone, or the variance at another level) is rejected."""
    a, b, steps = 150.0, 100.0, 4
    noise = NoiseModel(1.0, 0.08)
    delta = 2 * np.pi * np.arange(steps) / steps
    clean = a + b * np.cos(PHASES[None, :] + delta[:, None])
    phi, _, _ = sinusoidal_phase(_noisy(clean, noise, 11))
    measured = _circular_std(phi)
    read_only = phase_std_sinusoidal(b, noise.read_dn, steps)
    assert np.all(measured / read_only > 2.0)
    right = phase_std_sinusoidal(b, noise.sigma(a), steps)
    assert np.all(np.abs(measured / right - 1) < TOL)


def test_unequal_shifts_and_offset_least_squares() -> None:
    shifts = np.array([0.0, 40.0, 90.0, 200.0, 230.0])
    offset = -90.0
    a, b = 100.0, 45.0
    noise = NoiseModel(2.0, 0.02)
    theta = PHASES + np.radians(offset)
    clean = a + b * np.cos(theta[None, :] + np.radians(shifts)[:, None])
    phi, _, _ = sinusoidal_phase_ls(_noisy(clean, noise, 5), shifts, phase_offset_deg=offset)
    measured = _circular_std(phi)
    predicted = phase_std_least_squares(
        shifts,
        PHASES,
        np.full(PHASES.shape, b),
        np.full(PHASES.shape, a),
        noise,
        phase_offset_deg=offset,
    )
    assert np.all(np.abs(measured / predicted - 1) < TOL)
    # unequal shifts make the std depend on the phase; the equal-shift formula misses that
    textbook = phase_std_sinusoidal(b, noise.sigma(a), shifts.size)
    assert np.ptp(predicted / textbook) > 0.5  # 0.81 .. 1.53 here
    assert np.max(np.abs(measured / textbook - 1)) > TOL


def test_tolerant_fit_of_the_unsaturated_shifts() -> None:
    """An 8-step set whose brightest shifts clip: the std of the fit of the rest."""
    steps, a, b = 8, 200.0, 90.0
    noise = NoiseModel(2.0)
    delta = 2 * np.pi * np.arange(steps) / steps
    clean = a + b * np.cos(PHASES[None, :] + delta[:, None])
    noisy = _noisy(clean, noise, 3)
    stack = np.minimum(noisy, 255.0)  # float images: clipped where the camera saturates
    usable = clean < 255 - 6 * noise.read_dn  # which shifts clip is the same for every draw
    stack = np.where(usable[:, None, :], np.minimum(noisy, 254.0), 255.0)
    phi, _, _, used = tolerant_phase(stack, np.degrees(delta), 8)
    assert set(np.unique(used)) == set(np.unique(usable.sum(0)))
    measured = _circular_std(phi)
    predicted = phase_std_least_squares(
        np.degrees(delta),
        PHASES,
        np.full(PHASES.shape, b),
        np.full(PHASES.shape, a),
        noise,
        usable=usable,
    )
    assert np.all(np.abs(measured / predicted - 1) < TOL)
    # equal noise: the same as tolerant_noise_gain (the module's LS covariance)
    for j, phase in enumerate(PHASES):
        gain = tolerant_noise_gain(np.degrees(delta), phase, usable[:, j])
        assert predicted[j] == pytest.approx(gain * noise.read_dn / b, rel=1e-10)
    # the full set's sqrt(2/N) is too optimistic where shifts were dropped (up to 1.26x here)
    full = phase_std_sinusoidal(b, noise.read_dn, steps)
    assert np.max(measured / full) > 1 + 3 * TOL


@pytest.mark.parametrize("steps", [2, 3])
def test_triangular_intensity_ratio(steps: int) -> None:
    """Eq. 2.9 (3-step) and Eq. 2.8 (2-step) against their decoders, away from the 2-step
    turning points (where the folded phase is clipped to [0, pi])."""
    pitch, a, b = 60, 110.0, 70.0
    noise = NoiseModel(1.0, 0.03)
    x = np.arange(pitch, dtype=np.float64)
    t = x / pitch
    clean = np.stack([a + b * fringe_profile(t + k / steps, "triangular") for k in range(steps)])
    rng = np.random.default_rng(steps)
    draws = 1500
    z = rng.standard_normal((steps, draws, pitch))
    noisy = clean[:, None, :] + noise.sigma(clean)[:, None, :] * z
    if steps == 3:
        phi, _, _ = triangular_3step(noisy, quality=False)
    else:
        # the envelope over one period per draw row, as the decoder estimates it
        phi = np.stack(
            [
                triangular_2step(noisy[:, i : i + 1, :], envelope_px=pitch)[0][0]
                for i in range(draws)
            ]
        )
    measured = _circular_std(phi)
    truth = 2 * np.pi * t
    predicted = phase_std_triangular(truth, np.full(pitch, b), np.full(pitch, a), noise, steps)
    if steps == 2:
        # the middle half of the folded range, |P| < 1/2: the envelope I_m is a noisy local
        # maximum shared by the row, which adds (pi/2) P dI_m / I_m to the phase; it is not in
        # the prediction and raises the std by up to 34 % near the turning points (|P| -> 1)
        # over a one-period envelope (measured here), less over wider ones
        folded = np.minimum(truth, 2 * np.pi - truth)
        keep = np.abs(folded - np.pi / 2) < np.pi / 4
        outer = ~keep & (folded > 0.3) & (np.pi - folded > 0.3)
        assert np.all(
            (measured[outer] / predicted[outer] > 1) & (measured[outer] / predicted[outer] < 1.4)
        )
    else:  # not within 4 std of a region boundary (the ratio's ordering flips)
        frac = (6 * truth / (2 * np.pi)) % 1
        edge = np.minimum(frac, 1 - frac) * 2 * np.pi / 6
        keep = edge > 4 * predicted
    ratio = measured[keep] / predicted[keep]
    assert keep.sum() >= pitch / 2
    tol = TOL if steps == 3 else 0.10
    assert np.all(np.abs(ratio - 1) < tol), ratio
    # a broken predictor: the sinusoidal sqrt(2/N) sigma / b at the same b
    sine = phase_std_sinusoidal(b, noise.sigma(a), 3) * np.ones(pitch)
    assert np.median(np.abs(measured[keep] / sine[keep] - 1)) > tol


def test_predict_phase_std_flags_kept_saturation_and_tolerant_needs_images() -> None:
    spec = FringeSpec("sinusoidal", 4, 8.0, imin=60, migl=255)
    x = np.arange(8.0)
    # 140 + 120 cos clips where a shift is within 17 degrees of the peak: every other pixel
    imgs = np.stack([np.minimum(140 + 120 * fringe_profile(x / 8 + k / 4, "sinusoidal"), 255)
                     for k in range(4)])[:, None]  # fmt: skip
    imgs = np.rint(imgs).astype(np.uint8)
    kept = decode_set(imgs, spec, 8, reject_saturated=False)
    std = predict_phase_std(kept, NoiseModel(1.0))
    sat = kept.saturation_count > 0
    assert sat.any() and (~sat).any()
    assert np.isnan(std[sat]).all() and np.isfinite(std[~sat & kept.valid]).all()
    from hdrfringe.core.saturation.tolerant import decode_set_tolerant

    tol = decode_set_tolerant(imgs, spec, 8)
    with pytest.raises(InputError, match="images and bit depth"):
        predict_phase_std(tol, NoiseModel(1.0))
    std_t = predict_phase_std(tol, NoiseModel(1.0), images=imgs, bit_depth=8)
    assert np.isfinite(std_t[tol.valid]).all()
    assert np.all(std_t[sat & tol.valid] > std[~sat & kept.valid].max())  # fewer shifts


def test_noise_estimate_recovers_read_and_shot_noise() -> None:
    """8-step sets over a wide range of mean intensity: the residual (5 dof) pooled by level."""
    read, gain = 1.5, 0.04
    spec = FringeSpec("sinusoidal", 8, 16.0)
    cols = np.mgrid[0:60, 0:160][1]
    a = 30 + 1.3 * cols  # 30 .. 237
    b = 0.25 * a
    delta = spec.shifts
    clean = a + b * np.cos(2 * np.pi * cols / 16 + delta[:, None, None])
    rng = np.random.default_rng(0)
    noisy = clean + np.sqrt(read**2 + gain * clean) * rng.standard_normal(clean.shape)
    imgs = np.rint(noisy).astype(np.uint16)  # rounding adds 1/12 DN^2 to the read noise
    model = estimate_noise([(imgs, spec)], 16)
    assert model.read_dn == pytest.approx(np.sqrt(read**2 + 1 / 12), rel=0.1)
    assert model.gain_dn_per_e == pytest.approx(gain, rel=0.1)
    assert model.pixels == 60 * 160
    # dof correction: without it (median of chi2_5 / 5 = 0.87) the level is 13 % low
    est = fit_noise_model([100.0] * 1000, rng.chisquare(5, 1000) / 5 * 4.0, 5)
    assert est.read_dn**2 == pytest.approx(4.0, rel=0.08)
    with pytest.raises(InputError, match="4 or more shifts"):
        estimate_noise([(imgs[:3], FringeSpec("sinusoidal", 3, 16.0))], 16)


def test_noise_from_manifest_and_bad_values() -> None:
    assert noise_from_manifest({}) is None
    m = noise_from_manifest({"read_noise_dn": 2, "gain_dn_per_e": 0.5})
    assert m is not None and (m.read_dn, m.gain_dn_per_e) == (2.0, 0.5)
    with pytest.raises(InputError, match="read_dn must be finite and >= 0"):
        noise_from_manifest({"read_noise_dn": -1})
    with pytest.raises(InputError, match="must be a number"):
        NoiseModel("1")  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("model", "coef"),
    [
        ("linear", [[[-0.8]]]),
        ("rational", [[[1.5]], [[0.05]]]),
        ("poly2", [[[0.7]], [[0.01]]]),
        ("poly3", [[[0.7]], [[0.01]], [[-0.001]]]),
    ],
)
def test_height_derivative_matches_the_model_numerically(model: str, coef: list) -> None:
    from hdrfringe.core.calibration import evaluate_model

    c = np.array(coef, dtype=np.float64)
    d = np.array([[7.3]])
    h = 1e-5
    numeric = (evaluate_model(c, d + h, model) - evaluate_model(c, d - h, model)) / (2 * h)
    assert height_derivative(c, d, model) == pytest.approx(numeric, rel=1e-7)


def test_noise_estimate_of_rounded_four_step_images_is_not_a_median() -> None:
    """4-step residuals of integer images take few values (1 dof each): their median, even
    corrected by the chi-square median, is 15 % low in variance; the cut mean is not."""
    from hdrfringe.core.uncertainty import _chi2_factors

    spec = FringeSpec("sinusoidal", 4, 16.0)
    cols = np.mgrid[0:100, 0:160][1]
    clean = 118 + 60 * np.cos(2 * np.pi * cols / 16 + spec.shifts[:, None, None])
    rng = np.random.default_rng(2)
    noisy = clean + np.sqrt(1 + 0.01275 * clean) * rng.standard_normal(clean.shape)
    imgs = np.rint(noisy).astype(np.uint8)
    truth = 1 + 1 / 12 + 0.01275 * 118  # the variance at the mean level, rounding included
    model = estimate_noise([(imgs, spec)], 8)
    assert model.variance(118.0) / truth == pytest.approx(1, abs=0.05)  # measured 0.983
    design = np.column_stack([np.ones(4), np.cos(spec.shifts), -np.sin(spec.shifts)])
    flat = imgs.reshape(4, -1).astype(np.float64)
    resid = flat - design @ (np.linalg.pinv(design) @ flat)
    median = np.median((resid**2).sum(0) / _chi2_factors(1)[0])
    assert median / truth < 0.9  # measured 0.849


def test_chi2_table_equals_scipy() -> None:
    """The precomputed chi-square factors (no scipy import in a ``phase`` run) are scipy's own,
    for every tabulated nu; other nu still go through scipy."""
    from hdrfringe.core.uncertainty import _CHI2_TABLE, _chi2_factors, _chi2_factors_scipy

    nus = np.arange(1, len(_CHI2_TABLE) + 1)
    for tabulated, computed in zip(_chi2_factors(nus), _chi2_factors_scipy(nus), strict=True):
        np.testing.assert_allclose(tabulated, computed, rtol=1e-14, atol=0)
    mixed = np.array([[1.0, 2.5], [40.0, 3.0]])  # a fractional and an untabulated nu
    for got, computed in zip(_chi2_factors(mixed), _chi2_factors_scipy(mixed), strict=True):
        np.testing.assert_allclose(got, computed, rtol=1e-14, atol=0)
