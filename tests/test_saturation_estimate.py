"""DPA building blocks: saturated-intensity estimate (Eq. 6.2 and least squares), the error
correction polynomial (Eq. 6.3-6.4), the CDF of saturated intensities and the step rules."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hdrfringe.core.saturation.dpa_rules import (
    LOWEST_MIGL_TOLERANCE,
    SaturationCDF,
    index_image_cdf,
    initial_dpa_state,
    lowest_migl_rule,
    next_capture_migl,
    saturated_intensity_cdf,
    threshold_rule,
    update_cdf_with_newly_estimable,
    update_cdf_with_newly_unsaturated,
    update_dpa_state,
)
from hdrfringe.core.saturation.estimate import (
    CorrectionPolynomial,
    estimate_saturated_eq62,
    estimate_saturated_lsq,
    fit_unsaturated_sinusoid,
    sinusoid_trough,
    train_correction,
    training_data_from_rig,
    true_peak_scaled,
    true_peak_thesis,
    unsaturation_migl,
)
from hdrfringe.errors import InputError, OutputExistsError
from hdrfringe.rig.scenes import white_plate
from hdrfringe.rig.simulated import CameraModel, Lighting, RigGeometry, SimulatedRig

FULL = 255


def sinusoids(n: int, a, b, phi) -> np.ndarray:
    """Analytic stack ``a + b cos(phi + 2*pi*k/N)``, shape (N, ...)."""
    k = np.arange(n).reshape((n,) + (1,) * np.ndim(phi))
    return a + b * np.cos(phi + 2.0 * np.pi * k / n)


def rmse(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


# ---------------------------------------------------------------------------------------------
# Eq. 6.2 and least squares on analytic sinusoids
# ---------------------------------------------------------------------------------------------
def test_eq62_exact_with_one_clipped_shift_at_every_position():
    phi = np.linspace(0, 2 * np.pi, 400, endpoint=False).reshape(20, 20)
    true = sinusoids(4, 190.0, 80.0, phi)  # peak 270; second-highest at most 246.6
    clipped = np.minimum(true, FULL)
    sat = true >= FULL
    one = sat.sum(axis=0) == 1
    for k in range(4):  # every shift is the saturated one somewhere
        assert np.any(one & sat[k])
    peak, stack = estimate_saturated_eq62(clipped, 8, return_stack=True)
    np.testing.assert_allclose(stack[:, one], true[:, one], rtol=0, atol=1e-9)
    np.testing.assert_allclose(peak[one], true.max(axis=0)[one], rtol=0, atol=1e-9)
    none = sat.sum(axis=0) == 0
    assert none.any()
    np.testing.assert_array_equal(peak[none], clipped.max(axis=0)[none])


def test_eq62_matches_the_thesis_formulas_with_one_based_indices():
    rng = np.random.default_rng(1)
    ours = rng.uniform(0, 254, (4, 50))
    # thesis I_i, i = 1..4, shift 2*pi*i/4: I_4 has shift 2*pi, i.e. our shift 0
    thesis = {i: ours[i % 4] for i in range(1, 5)}
    formulas = {  # Eq. 6.2 as printed
        1: thesis[4] - thesis[3] + thesis[2],
        2: thesis[3] - thesis[4] + thesis[1],
        3: thesis[2] - thesis[1] + thesis[4],
        4: thesis[1] - thesis[2] + thesis[3],
    }
    for i, expected in formulas.items():
        imgs = ours.copy()
        imgs[i % 4] = FULL
        _, stack = estimate_saturated_eq62(imgs[:, None, :], 8, return_stack=True)
        np.testing.assert_allclose(stack[i % 4, 0], expected, atol=1e-12)


def test_lsq_equals_eq62_for_four_steps():
    rng = np.random.default_rng(2)
    imgs = rng.integers(0, 255, (4, 60, 70)).astype(np.uint8)
    which = rng.integers(0, 4, (60, 70))
    mask = rng.random((60, 70)) < 0.6
    for k in range(4):
        imgs[k][mask & (which == k)] = FULL
    p62, s62 = estimate_saturated_eq62(imgs, 8, return_stack=True)
    pls, sls = estimate_saturated_lsq(imgs, 8, return_stack=True)
    one = mask
    np.testing.assert_allclose(pls[one], p62[one], rtol=0, atol=1e-9)
    np.testing.assert_allclose(sls[:, one], s62[:, one], rtol=0, atol=1e-9)
    np.testing.assert_array_equal(pls[~mask], p62[~mask])  # unsaturated: observed maximum


@pytest.mark.parametrize("n", [5, 6, 7, 8])
def test_lsq_exact_up_to_n_minus_3_saturated_and_nan_beyond(n):
    rng = np.random.default_rng(n)
    shape = (50, 60)
    a = rng.uniform(120, 320, shape)
    b = rng.uniform(40, 160, shape)
    phi = rng.uniform(0, 2 * np.pi, shape)
    true = sinusoids(n, a, b, phi)
    clipped = np.minimum(true, FULL)
    count = (true >= FULL).sum(axis=0)
    for m in range(1, n - 2):
        assert np.any(count == m), f"no pixel with {m} saturated shifts"
    assert np.any(count > n - 3)
    peak, stack = estimate_saturated_lsq(clipped, 8, return_stack=True)
    ok = count <= n - 3
    np.testing.assert_allclose(stack[:, ok], true[:, ok], rtol=0, atol=1e-8)
    np.testing.assert_allclose(peak[ok], true.max(axis=0)[ok], rtol=0, atol=1e-8)
    assert np.all(np.isnan(peak[~ok]))
    assert np.all(np.isnan(stack[:, ~ok]))
    # the fit recovers the sinusoid's parameters where it is estimable
    fa, fb, fphi = fit_unsaturated_sinusoid(clipped, 8)
    np.testing.assert_allclose(fa[ok], a[ok], atol=1e-8)
    np.testing.assert_allclose(fb[ok], b[ok], atol=1e-8)
    dphi = np.angle(np.exp(1j * (fphi[ok] - phi[ok])))
    assert np.max(np.abs(dphi)) < 1e-9


def test_nan_when_too_many_saturated_and_bad_inputs():
    imgs = np.full((4, 2, 2), 100, dtype=np.uint8)
    imgs[:2, 0, 0] = FULL  # two saturated: Eq. 6.2 does not apply
    imgs[0, 1, 1] = FULL
    p62 = estimate_saturated_eq62(imgs, 8)
    pls = estimate_saturated_lsq(imgs, 8)
    assert np.isnan(p62[0, 0]) and np.isnan(pls[0, 0])
    assert p62[1, 1] == pytest.approx(100.0) and pls[1, 1] == pytest.approx(100.0)
    with pytest.raises(InputError, match="4-step"):
        estimate_saturated_eq62(np.zeros((5, 2, 2)), 8)
    with pytest.raises(InputError, match="above 2\\^B - 1"):
        estimate_saturated_lsq(np.full((4, 2, 2), 300, dtype=np.uint16), 8)
    with pytest.raises(InputError, match="shape"):
        estimate_saturated_lsq(np.zeros((4, 2)), 8)


# ---------------------------------------------------------------------------------------------
# training truth and its inverse
# ---------------------------------------------------------------------------------------------
def test_true_peak_models_and_their_inverses():
    idx = np.array([[200.0, 255.0], [-1.0, 41.0]])
    t = true_peak_thesis(idx, 8, 255)
    assert t[0, 0] == 255 + 55 and t[0, 1] == 255 and np.isnan(t[1, 0])
    # the thesis inverse returns N exactly
    assert unsaturation_migl(t[0, 0], 255, 40, 8, model="thesis") == 200.0

    # scaled: a pixel with I = A + s*g, pattern g_k = imin + (m - imin) c_k
    imin, top, A, s = 40.0, 255.0, 100.0, 0.9
    c = (1 + np.cos(0.3 + 2 * np.pi * np.arange(4) / 4)) / 2

    def stack_at(m):
        return (A + s * (m - imin) * c)[:, None, None]

    truth_top = stack_at(top).max()
    est = true_peak_scaled(stack_at(190.0), 190.0, 8, top, imin, offset=A)
    assert est[0, 0] == pytest.approx(truth_top, abs=1e-9)
    # default offset: the trough a - b of the fit is exactly A for an unblurred sinusoid
    est = true_peak_scaled(stack_at(190.0), 190.0, 8, top, imin)
    assert est[0, 0] == pytest.approx(truth_top, abs=1e-9)
    m = unsaturation_migl(np.array([truth_top]), top, imin, 8, model="scaled", offset=A)
    assert stack_at(m[0]).max() == pytest.approx(FULL - 0.5, abs=1e-9)
    # an offset at full scale never unsaturates
    m = unsaturation_migl(np.array([300.0]), top, imin, 8, model="scaled", offset=260.0)
    assert m[0] == -np.inf
    with pytest.raises(InputError, match="offset"):
        unsaturation_migl(np.array([300.0]), top, imin, 8, model="scaled")


# ---------------------------------------------------------------------------------------------
# the virtual rig: white plate under 600 lx, noise on
# ---------------------------------------------------------------------------------------------
def small_rig(depth_mm: float, seed: int) -> SimulatedRig:
    """The default rig cropped to the central 80 mm (0.5 mm per pixel, as the full camera)."""
    return SimulatedRig(
        white_plate(depth_mm),
        camera=CameraModel(width=160, height=120),
        geometry=RigGeometry(camera_field_mm=80.0),
        lighting=Lighting(ambient_lux=600),
        seed=seed,
    )


@pytest.fixture(scope="module")
def sweeps():
    """Training sweep (plate at 0 mm, seed 0) and a held-out sweep (6 mm, seed 1)."""
    return training_data_from_rig(small_rig(0.0, 0)), training_data_from_rig(small_rig(6.0, 1))


def test_estimate_against_rig_ground_truth(sweeps):
    _, data = sweeps
    top = data.images_at_top
    count = (top == FULL).sum(axis=0)
    one = count == 1
    assert one.mean() > 0.3 and (count > 1).any()  # peaks saturate, some twice
    peak = estimate_saturated_eq62(top, 8)
    truth = data.expected_at_top.max(axis=0)  # noise-free, unclipped
    err = peak[one] - truth[one]
    # noise only: read 1 DN + shot noise at ~250 DN gives ~1.9 DN per sample, sqrt(3) of it
    # in Eq. 6.2 (measured: bias +0.4, RMSE 3.3 DN)
    print(f"Eq. 6.2 vs expected_signal: bias {err.mean():.2f} DN, RMSE {rmse(err):.2f} DN")
    assert abs(err.mean()) < 1.0
    assert rmse(err) < 4.5
    assert np.all(truth[one] > FULL - 1)  # what saturated was really above full scale


def test_training_sweep_index_image(sweeps):
    data, _ = sweeps
    top = data.images_at_top
    sat = np.any(top == FULL, axis=0)
    assert np.all(data.index_image[~sat] == 255)
    assert np.all((data.index_image[sat] >= 41) & (data.index_image[sat] < 255))
    assert np.all(data.composite < FULL)  # every pixel unsaturated at its index
    # the reference set: an independent capture `margin` gray levels lower
    assert np.all(data.reference_migl == data.index_image - 10)


def test_scaled_truth_is_unbiased_against_the_rig(sweeps):
    data, _ = sweeps
    top = data.images_at_top
    one = (top == FULL).sum(axis=0) == 1
    ref = true_peak_scaled(
        data.reference, data.reference_migl.astype(float), 8, 255, 40, offset=data.offset
    )
    truth = data.expected_at_top.max(axis=0)
    err = (ref - truth)[one & np.isfinite(ref)]
    assert abs(err.mean()) < 1.0  # measured -0.1 DN on the full camera
    thesis = true_peak_thesis(data.index_image, 8)[one] - truth[one]
    assert thesis.mean() > 8  # one DN per gray level overstates our 0.7-0.8 DN per level


@pytest.mark.parametrize("truth", ["scaled", "thesis"])
def test_correction_reduces_rmse_on_held_out_data(sweeps, truth):
    train, held_out = sweeps
    poly = train.train(2, truth=truth)
    assert poly.truth == truth and poly.n_samples > 1000
    assert poly.rmse_after < poly.rmse_before
    est, true = held_out.samples(truth=truth)
    before, after = rmse(est - true), rmse(poly.apply(est) - true)
    print(f"{truth}: held-out RMSE {before:.2f} -> {after:.2f} DN (thesis: 71.05 -> 2.99)")
    assert after < before
    if truth == "thesis":  # mostly a scale bias, which the polynomial removes
        assert after < 0.4 * before


def test_train_correction_direct_call_and_errors(sweeps):
    data, _ = sweeps
    poly = train_correction(
        data.index_image, data.images_at_top, 8, 255, 40, 3, truth="thesis", metadata={"x": 1}
    )
    assert poly.order == 3 and len(poly.coefficients) == 4 and poly.metadata == {"x": 1}
    with pytest.raises(InputError, match="unsaturated images"):
        train_correction(data.index_image, data.images_at_top, 8, truth="scaled")
    with pytest.raises(InputError, match="usable training pixels"):
        train_correction(
            data.index_image,
            data.images_at_top,
            8,
            truth="thesis",
            mask=np.zeros(data.index_image.shape, dtype=bool),
        )


def test_correction_save_load_round_trip(tmp_path, sweeps):
    data, _ = sweeps
    poly = data.train(2)
    path = poly.save(tmp_path / "corr.json")
    back = CorrectionPolynomial.load(path)
    assert back == poly
    x = np.linspace(250, 340, 50)
    np.testing.assert_array_equal(back.apply(x), poly.apply(x))
    stored = json.loads(path.read_text())
    assert stored["format"] == "hdrfringe-correction-polynomial" and stored["order"] == 2
    assert stored["metadata"]["pitch_px"] == 20.0
    with pytest.raises(OutputExistsError, match="force=True"):
        poly.save(path)
    poly.save(path, force=True)
    (tmp_path / "bad.json").write_text('{"format": "something else"}')
    with pytest.raises(InputError, match="not a correction polynomial"):
        CorrectionPolynomial.load(tmp_path / "bad.json")
    with pytest.raises(InputError, match="does not exist"):
        CorrectionPolynomial.load(tmp_path / "missing.json")


def test_correction_apply_clips_to_domain():
    poly = CorrectionPolynomial((1.0, 2.0), (260.0, 300.0))  # eps = 1 + 2 t, t in [-1, 1]
    assert poly.error(260.0) == pytest.approx(-1.0) and poly.error(300.0) == pytest.approx(3.0)
    assert poly.error(400.0) == pytest.approx(3.0)  # constant beyond the domain
    assert poly.error(400.0, outside="zero") == 0.0
    assert poly.apply(300.0) == pytest.approx(297.0)
    assert np.isnan(poly.apply(np.nan))
    assert CorrectionPolynomial.identity().apply(280.0) == 280.0


# ---------------------------------------------------------------------------------------------
# CDF and step rules
# ---------------------------------------------------------------------------------------------
def thesis_estimates(migls) -> np.ndarray:
    """Peaks that, under Eq. 6.3's model, unsaturate exactly at ``migls`` (from MIGL 255)."""
    return FULL + (255 - np.asarray(migls, dtype=float))


def test_cdf_monotone_in_unit_interval(sweeps):
    data, _ = sweeps
    top = data.images_at_top
    count = (top == FULL).sum(axis=0)
    peak = data.train(2).apply(estimate_saturated_lsq(top, 8))
    cdf = saturated_intensity_cdf(
        peak, 255, 40, saturated=count > 0, offset=sinusoid_trough(top, 8), lowest_migl=60
    )
    v = cdf.values
    assert v.shape == (256,)
    assert np.all(np.diff(v) <= 0)  # grows as the MIGL falls
    assert v.min() >= 0 and v.max() <= 1
    assert v[255] == 0  # nothing saturated at 255 is unsaturated there
    assert cdf.total == int((count > 0).sum())
    # pixels with two saturated shifts are not estimable: F stays below 1 at the lowest MIGL
    assert cdf.at(60) == pytest.approx(cdf.accounted / cdf.total) and cdf.at(60) < 1
    actual = index_image_cdf(data.index_image, count > 0, 255, 60)
    assert actual.at(60) == 1.0 and np.all(np.diff(actual.values) <= 0)


def test_cdf_bins_and_total():
    est = np.array([thesis_estimates([250, 250, 240])[0], *thesis_estimates([250, 240]), np.nan])
    cdf = saturated_intensity_cdf(est, 255, 40, model="thesis")
    assert cdf.total == 4 and cdf.accounted == 3
    assert cdf.counts[250] == 2 and cdf.counts[240] == 1
    assert cdf.at(251) == 0 and cdf.at(250) == 0.5 and cdf.at(240) == 0.75
    # an estimate at (or below) full scale still unsaturates only below the initial MIGL
    cdf = saturated_intensity_cdf(np.array([250.0]), 255, 40, model="thesis")
    assert cdf.counts[254] == 1
    # below the lowest MIGL: in the total, not in the histogram
    cdf = saturated_intensity_cdf(thesis_estimates([30.0]), 255, 40, model="thesis")
    assert cdf.beyond == 1 and cdf.accounted == 0


def constructed_cdf(spec: dict[int, int], total: int, lowest: int = 41) -> SaturationCDF:
    counts = np.zeros(256, dtype=np.int64)
    for m, c in spec.items():
        counts[m] = c
    return SaturationCDF(counts, total, 255, lowest)


def test_threshold_rule():
    cdf = constructed_cdf({250: 10, 245: 5, 240: 20, 200: 65}, 100)
    assert not threshold_rule(cdf, 250, 0.0, 0.10)  # exactly 10 %: not more
    assert threshold_rule(cdf, 245, 0.0, 0.10)
    assert next_capture_migl(cdf, 255, 0.0, 0.10) == 245
    assert next_capture_migl(cdf, 255, 0.0, 0.20) == 240
    # after capturing at 240 (F = 0.35), the next 10 % gain is at 200
    assert next_capture_migl(cdf, 240, cdf.at(240), 0.10) == 200
    assert next_capture_migl(cdf, 240, threshold=0.10) == 200  # default: F at current MIGL
    with pytest.raises(InputError, match=r"0\.1 for 10 %"):
        next_capture_migl(cdf, 255, 0.0, 10)


def test_lowest_migl_rule():
    # half of the pixels estimated at 250, the other half not estimable (pending)
    cdf = constructed_cdf({250: 50}, 100)
    assert lowest_migl_rule(cdf, 249) and not lowest_migl_rule(cdf, 251)
    # the threshold rule alone would never fire again: the 0.01 % rule captures at 249
    assert next_capture_migl(cdf, 250, threshold=0.2) == 249
    assert next_capture_migl(cdf, 250, threshold=0.2, lowest_tolerance=None) is None
    # one pixel in 20000 lower down is within 0.01 %; one in 1000 is not
    cdf = constructed_cdf({250: 10000, 100: 1}, 20000)
    assert next_capture_migl(cdf, 250, threshold=0.2) == 249
    cdf = constructed_cdf({250: 500, 100: 1}, 1000)
    assert not lowest_migl_rule(cdf, 249, LOWEST_MIGL_TOLERANCE)
    assert next_capture_migl(cdf, 250, threshold=0.2) == 100
    # at the lowest MIGL there is nothing left to try
    assert next_capture_migl(cdf, 41, threshold=0.2) is None


def test_update_with_newly_estimable():
    cdf = constructed_cdf({250: 2}, 6)
    pending = np.array([True, True, True, False])  # three never estimated
    n_sat = np.array([1, 2, 0, 1])
    # estimates at capture MIGL 230: pixel 0 unsaturates 10 levels lower (thesis model)
    est = np.array([FULL + 10.0, np.nan, 200.0, FULL + 5.0])
    new, still = update_cdf_with_newly_estimable(cdf, pending, est, n_sat, 230, 40, model="thesis")
    assert new.counts[220] == 1 and new.accounted == 3  # only pixel 0 was added
    np.testing.assert_array_equal(still, [False, True, True, False])
    assert new.at(220) - cdf.at(220) == pytest.approx(1 / 6)
    assert cdf.accounted == 2  # pure: the input is unchanged


def test_update_with_newly_unsaturated():
    cdf = constructed_cdf({250: 2}, 6)
    pending = np.array([True, True, False, True])
    n_sat = np.array([0, 2, 0, 0])
    new, still = update_cdf_with_newly_unsaturated(cdf, pending, n_sat, 230)
    assert new.counts[230] == 2 and new.accounted == 4
    np.testing.assert_array_equal(still, [False, True, False, False])
    assert new.at(230) == pytest.approx(4 / 6) and new.at(231) == pytest.approx(2 / 6)


def test_dpa_state_round():
    # four saturated pixels at 255: two estimable (unsaturate at 250, 240), two not
    est0 = np.array([thesis_estimates([250])[0], thesis_estimates([240])[0], np.nan, np.nan])
    n0 = np.array([1, 1, 2, 3])
    state = initial_dpa_state(est0, n0, 255, 40, model="thesis")
    assert state.cdf.at(250) == 0.25 and state.pending.tolist() == [False, False, True, True]
    m = next_capture_migl(state.cdf, 255, state.last_captured_cdf_value, 0.3)
    assert m == 240
    # at 240: pixel 2 has one saturated shift left (unsaturates at 235), pixel 3 is unsaturated
    est1 = np.array([np.nan, np.nan, FULL + 5.0, np.nan])
    n1 = np.array([0, 0, 1, 0])
    state = update_dpa_state(state, est1, n1, m, 40, rule="threshold", model="thesis")
    assert state.cdf.counts[235] == 1 and state.cdf.counts[240] == 2
    assert not state.pending.any() and state.cdf.at(state.cdf.lowest_migl) == 1.0
    assert state.captures == ((255, "initial"), (240, "threshold"))
    assert state.last_captured_cdf_value == 0.75


def test_peak_and_trough_on_a_subset_equals_the_full_fits() -> None:
    """DPA fits only the pixels still pending: the values equal the whole-image functions."""
    from hdrfringe.core.saturation.estimate import (
        estimate_saturated_lsq,
        peak_and_trough,
        sinusoid_trough,
    )

    rng = np.random.default_rng(3)
    phi = rng.uniform(0, 2 * np.pi, (30, 40))
    amp = rng.uniform(20, 150, phi.shape)
    stack = np.stack([120 + amp * np.cos(phi + 2 * np.pi * k / 5) for k in range(5)])
    imgs = np.clip(np.rint(stack), 0, 255).astype(np.uint8)
    pixels = rng.random(phi.shape) < 0.5
    peak, trough = peak_and_trough(imgs, 8, pixels)
    full_peak, full_trough = estimate_saturated_lsq(imgs, 8), sinusoid_trough(imgs, 8)
    assert np.array_equal(peak[pixels], full_peak[pixels], equal_nan=True)
    assert np.array_equal(trough[pixels], full_trough[pixels], equal_nan=True)
    assert np.isnan(peak[~pixels]).all() and np.isnan(trough[~pixels]).all()
    assert np.isfinite(peak).sum() > 100  # some pixels are estimable, some saturated
    assert (imgs == 255).any()


@pytest.mark.parametrize("n", [4, 5, 6, 8])
def test_saturated_peak_lower_bound_never_exceeds_the_true_peak(n: int) -> None:
    """The bound holds for any offset, amplitude and phase, up to the rounding of the
    unsaturated samples (at most 1.5 DN); NaN where nothing or everything is saturated."""
    from hdrfringe.core.saturation.estimate import saturated_peak_lower_bound

    rng = np.random.default_rng(n)
    m = 20000
    a = rng.uniform(30, 600, m)
    b = rng.uniform(0, 1, m) * a
    phi = rng.uniform(0, 2 * np.pi, m)
    d = 2 * np.pi * np.arange(n)[:, None] / n
    true = a + b * np.cos(phi + d)
    obs = np.clip(np.rint(true), 0, 255).astype(np.uint8)[:, :, None]
    bound = saturated_peak_lower_bound(obs, 8)[:, 0]
    count = (obs[:, :, 0] == 255).sum(axis=0)
    assert np.all(np.isnan(bound[(count == 0) | (count == n)]))
    some = (count > 0) & (count < n)
    assert some.mean() > 0.2 and np.all(np.isfinite(bound[some]))
    assert np.all(bound[some] <= (a + b)[some] + 1.5)
    assert np.median(bound[some] / (a + b)[some]) > 0.5  # informative, not just 255
    if n == 4:  # three saturated shifts: 2F - I_u
        three = count == 3
        u = np.where(obs[:, three, 0] == 255, 999, obs[:, three, 0].astype(int)).min(axis=0)
        np.testing.assert_allclose(bound[three], 510.0 - u)
