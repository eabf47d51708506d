"""Phase decoding on analytic fringes: convention, quality maps, saturation count, validity."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hdrfringe.core.patterns import FringeSpec, fringe_gray
from hdrfringe.core.phase import (
    data_modulation,
    decode_set,
    saturation_count,
    sinusoidal_phase,
    triangular_2step,
    triangular_3step,
    wrapped_phase,
)
from hdrfringe.errors import InputError
from tests.conftest import synthetic_set

TWO_PI = 2 * np.pi


def wrap_err(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(np.angle(np.exp(1j * (a - b))))


def analytic(spec: FringeSpec, x: np.ndarray, gain: float = 100.0, offset: float = 30.0):
    return np.stack([offset + gain * fringe_gray(x, spec, k) for k in range(spec.steps)])


@given(
    n=st.integers(3, 12),
    pitch=st.floats(3.0, 40.0),
    gain=st.floats(0.05, 300.0),
    offset=st.floats(0.0, 500.0),
)
@settings(max_examples=60, deadline=None)
def test_sinusoidal_phase_is_exact_for_any_n_pitch_gain(n, pitch, gain, offset) -> None:
    spec = FringeSpec("sinusoidal", n, pitch)
    x = np.linspace(-30, 90, 257)[None, :]
    phi, b, a = sinusoidal_phase(analytic(spec, x, gain, offset))
    assert np.max(wrap_err(phi, TWO_PI * x / pitch)) < 1e-9
    assert np.all((phi >= 0) & (phi < TWO_PI))
    # Eq. 3.4-3.5 on the contract's pattern: b = gain*(migl-imin)/2, a = offset + gain*(migl+imin)/2
    assert np.allclose(b, gain * (spec.migl - spec.imin) / 2)
    assert np.allclose(a, offset + gain * (spec.migl + spec.imin) / 2)


def test_three_step_closed_form() -> None:
    """N = 3 of Eq. 2.2 is the closed form of Eq. 2.4, written for shifts 0, 2pi/3, 4pi/3.

    With I_1, I_2, I_3 the shifts 0, 1, 2: S = (sqrt(3)/2)(I_2 - I_3), C = (2I_1 - I_2 - I_3)/2,
    so phi = atan2(sqrt(3)(I_3 - I_2), 2I_1 - I_2 - I_3). (The thesis prints Eq. 2.4 with the
    opposite sign, which corresponds to shifts applied the other way; docs/phase.md.)
    """
    spec = FringeSpec("sinusoidal", 3, 6.7)
    x = np.linspace(0, 40, 301)[None, :]
    i1, i2, i3 = analytic(spec, x)
    closed = np.arctan2(np.sqrt(3) * (i3 - i2), 2 * i1 - i2 - i3)
    phi, _, _ = sinusoidal_phase(np.stack([i1, i2, i3]))
    assert np.max(wrap_err(closed, phi)) < 1e-9
    assert np.max(wrap_err(phi, TWO_PI * x / 6.7)) < 1e-9


@pytest.mark.parametrize("pitch", [6.0, 7.37, 13.1, 21.0])
def test_triangular_3step_recovers_contract_phase(pitch: float) -> None:
    spec = FringeSpec("triangular", 3, pitch)
    x = np.linspace(-10, 100, 1001)[None, :]
    imgs = analytic(spec, x, 80.0, 12.0)
    phi, b, a = triangular_3step(imgs)
    assert np.max(wrap_err(phi, TWO_PI * x / pitch)) < 1e-9
    assert np.allclose(b, 80.0 * (spec.migl - spec.imin) / 2)  # I_m / 2
    assert np.allclose(a, 12.0 + 80.0 * (spec.migl + spec.imin) / 2)


def test_triangular_2step_folded_and_unfolded_phase() -> None:
    pitch = 12.3
    spec = FringeSpec("triangular", 2, pitch)
    x = np.linspace(0, 120, 1200)[None, :].repeat(3, 0)
    imgs = analytic(spec, x, 100.0, 5.0)
    phi, folded, b, _ = triangular_2step(imgs)
    truth = np.mod(TWO_PI * x / pitch, TWO_PI)
    # what Eq. 2.8 alone determines: the folded phase min(phi, 2pi - phi)
    interior = slice(60, -60)
    f_true = np.minimum(truth, TWO_PI - truth)
    assert np.max(np.abs(folded - f_true)[:, interior]) < 0.05
    err = wrap_err(phi, truth)[:, interior]
    assert np.median(err) < 0.01
    assert np.max(err) < 0.1  # only near the turning points, where the envelope is sampled
    assert np.allclose(np.median(b), 100.0 * 215 / 2, rtol=0.02)


def test_saturation_count_is_exact() -> None:
    rng = np.random.default_rng(1)
    imgs = rng.integers(0, 255, size=(4, 30, 40), dtype=np.uint8)
    truth = np.zeros((30, 40), dtype=np.uint8)
    for k in range(4):
        m = rng.random((30, 40)) < 0.2
        imgs[k][m] = 255
        truth += m
    assert np.array_equal(saturation_count(imgs, 8), truth)
    # a 12-bit sensor in a 16-bit container saturates at 4095, not 65535
    imgs12 = imgs.astype(np.uint16) * 16
    imgs12[imgs == 255] = 4095
    assert np.array_equal(saturation_count(imgs12, 12), truth)


def test_decode_flags_saturated_and_low_modulation_pixels() -> None:
    spec = FringeSpec("sinusoidal", 4, 8.0)
    x = np.tile(np.linspace(0, 64, 64), (40, 1))
    gain = np.full_like(x, 0.9)
    gain[:10] = 2.0  # these rows clip
    gain[30:] = 0.005  # these rows have ~0.5 DN modulation
    imgs = np.stack([np.clip(np.rint(gain * fringe_gray(x, spec, k)), 0, 255) for k in range(4)])
    imgs = imgs.astype(np.uint8)
    res = decode_set(imgs, spec, 8)
    sat = res.saturation_count > 0
    assert sat[:10].mean() > 0.5 and not sat[10:].any()
    assert np.array_equal(res.valid, ~sat & (np.arange(40)[:, None] < 30))
    assert np.all(np.isnan(res.wrapped_phase[~res.valid]))
    assert np.all(np.isfinite(res.wrapped_phase[res.valid]))
    kept = decode_set(imgs, spec, 8, reject_saturated=False)
    assert kept.valid[:10].all()
    assert np.array_equal(kept.saturation_count, res.saturation_count)
    psi = data_modulation(res.modulation, res.mean_intensity)
    assert np.allclose(psi[10:30], res.data_modulation[10:30], equal_nan=True)


def test_decode_refuses_wrong_shift_count_and_overrange() -> None:
    spec = FringeSpec("sinusoidal", 4, 8.0)
    imgs = np.zeros((3, 5, 5), np.uint16)
    with pytest.raises(InputError, match="4-step set has 3 images"):
        decode_set(imgs, spec, 8)
    imgs = np.full((4, 5, 5), 300, np.uint16)
    with pytest.raises(InputError, match="above 2"):
        decode_set(imgs, spec, 8)
    with pytest.raises(InputError, match="not supported"):
        decode_set(np.zeros((4, 5, 5)), FringeSpec("triangular", 4, 8.0), 8)


def test_triangular_3step_order_statistics_match_sorting() -> None:
    """The min/max order statistics equal np.sort / argmax / argmin, ties included."""
    from hdrfringe.core.phase import _tri3_region_table

    rng = np.random.default_rng(5)
    stack = rng.integers(0, 6, (3, 40, 50)).astype(np.float64)  # many ties
    phase, modulation, _ = triangular_3step(stack)
    srt = np.sort(stack, axis=0)
    hi, lo = np.argmax(stack, axis=0), np.argmin(stack, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        r0 = (srt[2] - srt[1]) / (srt[2] - srt[0])
    region_tab, rising_tab = _tri3_region_table()
    code = 3 * hi + lo
    ratio = region_tab[code] + np.where(rising_tab[code], r0, 1.0 - r0)
    ratio[code == 4 * lo] = np.nan
    expected = np.mod(2 * np.pi * ratio / 6.0, 2 * np.pi)
    expected[expected >= 2 * np.pi] = 0.0
    assert np.array_equal(phase, expected, equal_nan=True)
    assert np.array_equal(modulation, 0.75 * (srt[2] - srt[0]))


@pytest.mark.parametrize("n", [3, 4, 8])
def test_float32_phase_alone_agrees_with_the_full_decoder(n: int) -> None:
    rng = np.random.default_rng(n)
    x = np.linspace(0, 60, 640)
    imgs = np.stack([120 + 90 * np.cos(2 * np.pi * x / 7 + 2 * np.pi * k / n) for k in range(n)])
    imgs = np.clip(np.rint(imgs[:, None, :] + rng.normal(0, 2, (n, 30, 640))), 0, 255)
    imgs = imgs.astype(np.uint8)
    fast, b, a = sinusoidal_phase(imgs, dtype=np.float32, quality=False)
    assert b is None and a is None
    full, b64, a64 = sinusoidal_phase(imgs)
    assert fast.dtype == np.float32 and fast.min() >= 0 and fast.max() < 2 * np.pi
    diff = np.angle(np.exp(1j * (fast.astype(np.float64) - full)))
    assert np.abs(diff).max() < 1e-5
    # the float64 phase does not depend on whether the quality maps are computed
    assert np.array_equal(sinusoidal_phase(imgs, quality=False)[0], full)
    _, b32, a32 = sinusoidal_phase(imgs, dtype=np.float32)
    assert b32.dtype == np.float32 and np.allclose(b32, b64, rtol=1e-5)
    assert np.allclose(a32, a64, rtol=1e-6)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_phase_zero_is_positive_zero_in_both_precisions(dtype) -> None:
    """atan2(-0, C > 0) is -0.0; the [0, 2 pi) wrap turns it into +0.0 in float32 too (the
    float32 path once wrapped only negatives and returned -0.0 there)."""
    imgs = np.array([[[200.0]], [[100.0]], [[100.0]], [[100.0]]])  # phi = 0 exactly: S = 0
    phi = sinusoidal_phase(imgs, dtype=dtype)[0]
    assert phi.dtype == dtype and phi[0, 0] == 0 and not np.signbit(phi[0, 0])


def test_sinusoidal_phase_refuses_other_dtypes() -> None:
    with pytest.raises(InputError, match="float32 or float64"):
        sinusoidal_phase(np.zeros((3, 2, 2)), dtype=np.float16)


@pytest.mark.parametrize(
    ("pattern", "steps"),
    [("sinusoidal", 3), ("sinusoidal", 4), ("triangular", 3), ("triangular", 2)],
)
def test_wrapped_phase_is_the_decoders_phase(pattern: str, steps: int) -> None:
    """wrapped_phase gives decode_set's phase bit for bit (every pixel kept), the same decoder;
    triangular sets refuse float32, sinusoidal ones decode in it."""
    spec = FringeSpec(pattern, steps, 9.3)
    x = np.linspace(0, 60, 200)[None, :].repeat(20, 0)
    rng = np.random.default_rng(steps)
    noisy = analytic(spec, x, 0.9, 10.0) + rng.normal(0, 1, (steps, 20, 200))
    imgs = np.clip(np.rint(noisy), 0, 255).astype(np.uint8)
    res = decode_set(imgs, spec, 8, min_modulation=0.0, reject_saturated=False)
    phase = wrapped_phase(imgs, spec)
    assert phase.dtype == np.float64
    assert np.array_equal(phase, res.wrapped_phase, equal_nan=True)
    if pattern == "triangular":
        with pytest.raises(InputError, match="float64 only"):
            wrapped_phase(imgs, spec, dtype=np.float32)
    else:
        fast = wrapped_phase(imgs, spec, dtype=np.float32)
        assert np.array_equal(fast, sinusoidal_phase(imgs, dtype=np.float32)[0])
    with pytest.raises(InputError, match=f"{steps}-step set has {steps + 1} images"):
        wrapped_phase(np.concatenate([imgs, imgs[:1]]), spec)


def test_triangular_3step_phase_does_not_depend_on_the_quality_maps() -> None:
    spec = FringeSpec("triangular", 3, 11.0)
    x = np.linspace(0, 50, 300)[None, :].repeat(4, 0)
    imgs = analytic(spec, x, 0.7, 3.0) + np.random.default_rng(3).normal(0, 1, (3, 4, 300))
    phi, b, a = triangular_3step(imgs, quality=False)
    assert b is None and a is None
    assert np.array_equal(phi, triangular_3step(imgs)[0], equal_nan=True)


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_a_batch_of_sets_decodes_as_each_set_alone(dtype) -> None:
    """One call on (N, n_sets, H, W) gives each set's phase, modulation and mean maps."""
    rng = np.random.default_rng(3)
    sets = []
    for pitch in (7.0, 13.0, 31.0):
        imgs, _ = synthetic_set(FringeSpec("sinusoidal", 5, pitch, "vertical", 40, 255))
        sets.append(np.clip(imgs + rng.integers(0, 3, imgs.shape), 0, 255))
    batch = sinusoidal_phase(np.stack(sets, axis=1), dtype=dtype)
    tol = 1e-12 if dtype == np.float64 else 1e-5
    for k, imgs in enumerate(sets):
        alone = sinusoidal_phase(imgs, dtype=dtype)
        for got, want in zip(batch, alone, strict=True):
            assert got.shape == (3, *imgs.shape[1:]) and got.dtype == dtype
            np.testing.assert_allclose(got[k], want, rtol=0, atol=tol)
