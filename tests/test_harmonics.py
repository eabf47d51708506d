"""Fringe-harmonic compensation (hdrfringe.core.harmonics, docs/harmonics.md).

References the code under test did not produce: closed-form phase errors of known amplitude
(the inverse series of ``phi = theta + A sin(6 theta)``), and the virtual rig's ground truth
(the projector column every pixel sees, ``2 pi u / p``). On the rig a gamma mismatch (patterns
not pre-compensated, true gamma 2.812) gives the fringes harmonics, i.e. a square-ish response;
with the default pre-compensation, or a continuous 16-bit projector, the fringes are
sinusoidal and the compensation must leave them alone.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.core.captures import Captures
from hdrfringe.core.decode import decode_captures
from hdrfringe.core.harmonics import (
    FLOOR_RAD,
    HarmonicError,
    compensate_sets,
    estimate_harmonic_error,
    harmonics_mode,
    not_applicable,
)
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.phase import decode_set
from hdrfringe.errors import InputError
from tests.conftest import run_cli

TWO_PI = 2 * np.pi
PITCH = 32.0  # projector px: about 15 camera px per period on the half-size rig


def _wrap(a: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * a))


def _surface(shape: tuple[int, int] = (240, 320), period: float = 22.0) -> np.ndarray:
    """A smooth, curved true phase: tilt plus a bump (about ``period`` px per fringe)."""
    yy, xx = np.mgrid[0 : shape[0], 0 : shape[1]].astype(float)
    bump = 40.0 * np.exp(-((xx - 160) ** 2 + (yy - 120) ** 2) / (2 * 60.0**2))
    return TWO_PI * (xx + 0.35 * yy + bump) / period


# --- closed forms ---------------------------------------------------------------------------


def _inverse_series(delta, orders: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """Fourier coefficients of ``eps(phi) = phi - theta`` for ``phi = theta + delta(theta)``,
    by quadrature over a dense uniform grid of ``theta`` (``d phi = phi'(theta) d theta``)."""
    theta = np.linspace(0, TWO_PI, 200_000, endpoint=False)
    d = delta(theta)
    phi = theta + d
    dphi = 1 + np.gradient(d, theta[1] - theta[0])
    a = np.array([2 * np.mean(d * np.cos(m * phi) * dphi) for m in orders])
    b = np.array([2 * np.mean(d * np.sin(m * phi) * dphi) for m in orders])
    return a, b


def test_recovers_a_known_error_on_a_curved_surface() -> None:
    """``phi = theta + 0.08 sin(6 theta) + 0.03 cos(3 theta)`` on a curved surface: the
    estimated coefficients are the inverse series' (computed by quadrature) to 0.002 rad, and
    the corrected phase matches ``theta`` to 0.01 rad where the error was 0.10 rad. Rejects a
    correction with the wrong sign (twice the error), the forward coefficients taken for the
    inverse ones, and regressors that were not high-passed (wrong amplitudes)."""
    theta = _surface(period=50.0)

    def delta(t):
        return 0.08 * np.sin(6 * t) + 0.03 * np.cos(3 * t)

    phi = np.mod(theta + delta(theta), TWO_PI)
    est = estimate_harmonic_error(phi, 3, orders=6)
    assert est.orders == (3, 6, 9, 12, 15, 18) and est.significant
    a, b = _inverse_series(delta, list(est.orders))
    np.testing.assert_allclose(est.cos, a, atol=0.002)
    np.testing.assert_allclose(est.sin, b, atol=0.002)
    assert abs(a[0] - 0.03) > 0.003 or abs(b[3]) > 0.01  # the inverse is not the forward series
    before = np.abs(_wrap(phi - theta)).max()
    after = np.abs(_wrap(est.correct(phi) - theta)).max()
    assert before > 0.1 and after < 0.01
    wrong_sign = np.abs(_wrap(phi + est.error(phi) - theta)).max()
    assert wrong_sign > 1.8 * before


def test_noise_alone_gives_coefficients_within_their_errors() -> None:
    """A sinusoidal decode's phase: smooth truth plus white noise 0.03 rad. Nothing is
    significant, every coefficient is within 4 jackknife standard errors of 0, and even a
    forced correction moves the phase by less than 1e-3 rad."""
    rng = np.random.default_rng(3)
    theta = _surface((300, 400))
    phi = np.mod(theta + rng.normal(0, 0.03, theta.shape), TWO_PI)
    est = estimate_harmonic_error(phi, 4, orders=3)
    coef = np.abs(np.array(est.cos + est.sin))
    se = np.array(est.cos_se + est.sin_se)
    assert not est.significant and est.rms_rad < FLOOR_RAD
    assert np.all(coef < 4 * se)
    assert np.nanmax(np.abs(_wrap(est.correct(phi) - phi))) < 1e-3


def test_mask_invalid_pixels_and_orders_beyond_resolution() -> None:
    """NaN pixels stay NaN; orders whose period is below 2.5 px along the gradient are left
    out (period 22/(1.06) px, N = 3: k = 1, 2); a 6 px fringe period resolves none."""
    theta = _surface()
    phi = np.mod(theta + 0.05 * np.sin(6 * theta), TWO_PI)
    phi[100:140, 50:90] = np.nan
    est = estimate_harmonic_error(phi, 3, orders=8)
    assert est.orders == (3, 6)
    assert np.isnan(est.correct(phi)[120, 70]) and np.isfinite(est.correct(phi)[0, 0])
    fine = np.mod(TWO_PI * np.mgrid[0:100, 0:100][1] / 6.0, TWO_PI)
    short = estimate_harmonic_error(fine, 3)
    assert short.orders == () and "too short" in short.reason and not short.significant
    assert short.summary() == {"steps": 3, "reason": short.reason}


@pytest.mark.parametrize("target", [250_000, 4_000])  # centre grid strides 1 and 3
def test_a_small_mask_gives_the_whole_images_estimate(
    target: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The estimator works on the bounding box of the masked pixels (a sphere's region costs
    its box, not the 2.8 Mpx image); the equations, their order and their jackknife tiles must
    be the whole image's. Two lone valid pixels in opposite corners make the box the whole image
    and add no equation (no neighbour: no centre, no period): the estimate must not change, bit
    for bit. Rejects a box whose start is off the centre grid (other centres) or tiles taken
    from the box (other standard errors)."""
    from hdrfringe.core import harmonics

    monkeypatch.setattr(harmonics, "TARGET_EQUATIONS", target)
    theta = _surface((300, 400))
    phi = np.mod(theta + 0.05 * np.sin(6 * theta) + 0.02 * np.cos(3 * theta), TWO_PI)
    yy, xx = np.mgrid[0:300, 0:400]
    region = (yy - 171) ** 2 + ((xx - 233) / 1.4) ** 2 < 95**2  # box from row 77, column 101
    corners = region.copy()
    corners[0, 0] = corners[-1, -1] = True
    boxed = estimate_harmonic_error(phi, 3, mask=region)
    whole = estimate_harmonic_error(phi, 3, mask=corners)
    assert boxed.reason == "" and boxed.equations > 2_000
    assert boxed == whole


def test_bad_arguments() -> None:
    for bad in ("on", "0", "9", "-1", "", 2.5):
        with pytest.raises(InputError, match="off, auto or a number"):
            harmonics_mode(bad)  # type: ignore[arg-type]
    assert harmonics_mode(3) == ("force", 3)
    phi = np.zeros((20, 20))
    with pytest.raises(InputError, match="2-D"):
        estimate_harmonic_error(phi[0], 3)
    with pytest.raises(InputError, match="steps"):
        estimate_harmonic_error(phi, 2)
    with pytest.raises(InputError, match="mask has shape"):
        estimate_harmonic_error(phi, 3, mask=np.ones((3, 3), bool))


def test_which_sets_are_modelled() -> None:
    assert not_applicable(FringeSpec(steps=4)) is None
    assert not_applicable(FringeSpec(steps=3, shifts_deg=(-120, 0, 120))) is None
    assert "not equally spaced" in str(not_applicable(FringeSpec(steps=3, shifts_deg=(0, 90, 200))))
    assert "triangular" in str(not_applicable(FringeSpec("triangular", 3, 8.0)))


# --- the virtual rig ------------------------------------------------------------------------


def _rig_set(steps: int, *, gamma_precompensation: float, continuous: bool = False):
    """One set on the half-size virtual rig (matte dome on a plate): images, decode, truth."""
    from hdrfringe.rig.scenes import glossy
    from hdrfringe.rig.simulated import CameraModel, ProjectorModel, SimulatedRig

    bits = 16 if continuous else 8
    full = 2**bits - 1
    projector = ProjectorModel(model="continuous" if continuous else "pixelated", bit_depth=bits)
    rig = SimulatedRig(
        glossy(specular=0.0),
        camera=CameraModel(width=324, height=247),
        projector_model=projector,
        gamma_precompensation=gamma_precompensation,
        seed=1,
    )
    spec = FringeSpec("sinusoidal", steps, PITCH, imin=40.0 * full / 255, migl=float(full))
    images = rig.capture(spec.frames())
    truth = 2 * np.pi * rig.truth().u / PITCH
    return rig, spec, images, decode_set(images, spec, 8), truth


def _systematic(phase: np.ndarray, truth: np.ndarray, bins: int = 48) -> float:
    """RMS over the true phase (binned) of the mean error: the phase-dependent part."""
    err = _wrap(phase - truth)
    ok = np.isfinite(err)
    b = (np.mod(truth[ok], TWO_PI) / TWO_PI * bins).astype(int)
    mean = np.bincount(b, err[ok], bins) / np.bincount(b, None, bins)
    return float(np.sqrt(np.mean((mean - mean.mean()) ** 2)))


@pytest.mark.parametrize("steps", [3, 4])
def test_inert_on_the_virtual_rigs_sinusoidal_fringes(steps: int) -> None:
    """Continuous 16-bit projector, gamma pre-compensated: pure sinusoids. Coefficients within
    4 standard errors of 0 (measured: within 1.7), auto leaves the phase bit for bit, a forced
    correction moves it by less than 5e-4 rad (measured 1-2e-4). The default 8-bit pixelated
    rig's pattern rounding leaves 0.0005 rad RMS (below the 1e-3 floor): auto leaves it too."""
    *_, res, _ = _rig_set(steps, gamma_precompensation=2.812, continuous=True)
    est = estimate_harmonic_error(res.wrapped_phase, steps, mask=res.valid)
    coef = np.abs(np.array(est.cos + est.sin))
    assert np.all(coef < 4 * np.array(est.cos_se + est.sin_se)), est
    assert not est.significant
    change = _wrap(est.correct(res.wrapped_phase) - res.wrapped_phase)
    assert np.nanmax(np.abs(change)) < 5e-4
    ratio = float(np.max(coef / np.array(est.cos_se + est.sin_se)))
    print(f"N={steps} pure sinusoids: max |coef|/se {ratio:.2f}, forced change "
          f"{np.nanmax(np.abs(change)):.2e} rad")  # fmt: skip
    *_, res8, _ = _rig_set(steps, gamma_precompensation=2.812)
    from hdrfringe.core.captures import FringeSet

    fs = FringeSet("s", FringeSpec("sinusoidal", steps, PITCH), tuple(range(steps)))
    out, summary = compensate_sets([fs], {"s": res8}, "auto")
    assert summary["sets"]["s"]["applied"] is False
    assert 1e-4 < summary["sets"]["s"]["rms_rad"] < FLOOR_RAD  # measured 0.00045, 0.0005
    print(f"N={steps} 8-bit rig: {summary['sets']['s']['rms_rad']:.5f} rad RMS estimated")
    assert out["s"] is res8  # not replaced: the same arrays


@pytest.mark.parametrize(("steps", "systematic", "total"), [(3, 0.15, 0.25), (4, 0.2, 0.9)])
def test_removes_a_gamma_mismatch_against_the_rigs_truth(
    steps: int, systematic: float, total: float
) -> None:
    """No pre-compensation (true gamma 2.812): the phase-dependent error against the truth
    falls to at most ``systematic`` of itself (measured 0.194 -> 0.022 rad for N = 3, 0.0173
    -> 0.0024 for N = 4) and the error std to ``total`` (measured 0.195 -> 0.037 for N = 3;
    for N = 4 the noise, 0.019, dominates after). Rejects the wrong sign and the wrong N
    (N = 4 orders on a 3-step set)."""
    *_, res, truth = _rig_set(steps, gamma_precompensation=1.0)
    phi = res.wrapped_phase
    est = estimate_harmonic_error(phi, steps, mask=res.valid)
    assert est.significant
    fixed = est.correct(phi)
    print(
        f"N={steps} gamma mismatch: systematic {_systematic(phi, truth):.4f} -> "
        f"{_systematic(fixed, truth):.4f} rad, std {np.nanstd(_wrap(phi - truth)):.4f} -> "
        f"{np.nanstd(_wrap(fixed - truth)):.4f} rad"
    )
    assert _systematic(fixed, truth) < systematic * _systematic(phi, truth)
    assert np.nanstd(_wrap(fixed - truth)) < total * np.nanstd(_wrap(phi - truth))
    assert _systematic(phi + est.error(phi), truth) > 1.5 * _systematic(phi, truth)
    if steps == 3:
        other = estimate_harmonic_error(phi, 4, mask=res.valid).correct(phi)
        assert _systematic(other, truth) > 0.8 * _systematic(phi, truth)


def test_decode_captures_applies_it_before_unwrapping() -> None:
    """A one-period set and a 32 px set on the gamma-mismatched rig: with ``auto`` the family's
    absolute phase is closer to the truth (the fine set's compensated phase is unwrapped), the
    decode records both sets; ``off`` is the decode of before (no record, same arrays)."""
    from hdrfringe.rig.scenes import glossy
    from hdrfringe.rig.simulated import CameraModel, SimulatedRig

    rig = SimulatedRig(
        glossy(specular=0.0), camera=CameraModel(width=324, height=247), gamma_precompensation=1.0
    )
    specs = [FringeSpec("sinusoidal", 3, 1024.0), FringeSpec("sinusoidal", 3, PITCH)]
    frames = [f for s in specs for f in s.frames()]
    caps = Captures(frames, rig.capture(frames), 8, projector=rig.projector)
    truth = TWO_PI * rig.truth().u / PITCH
    off = decode_captures(caps)
    assert off.harmonics is None
    same = decode_captures(caps, harmonics="off")
    for label, r in off.set_results.items():
        np.testing.assert_array_equal(same.set_results[label].wrapped_phase, r.wrapped_phase)
    auto = decode_captures(caps, harmonics="auto")
    assert auto.harmonics is not None and auto.harmonics["mode"] == "auto"
    assert all(e["applied"] for e in auto.harmonics["sets"].values())
    e_off = np.nanstd(off.primary.absolute_phase - truth)
    e_auto = np.nanstd(auto.primary.absolute_phase - truth)
    assert e_auto < 0.3 * e_off
    with pytest.raises(InputError, match="saturated='exclude'"):
        decode_captures(caps, saturated="exclude", harmonics="auto")


def test_a_triangular_set_is_left_as_decoded() -> None:
    from hdrfringe.core.captures import FringeSet

    spec = FringeSpec("triangular", 3, 16.0)
    res = decode_set(np.zeros((3, 8, 8), np.uint8) + np.arange(3)[:, None, None] * 50, spec, 8)
    fs = FringeSet("t", spec, (0, 1, 2))
    out, summary = compensate_sets([fs], {"t": res}, "auto")
    assert out["t"] is res
    assert summary["sets"]["t"] == {"applied": False, "reason": not_applicable(spec)}


def test_pixels_with_a_saturated_shift_do_not_enter_the_estimate() -> None:
    """With --keep-saturated the clipped pixels stay valid; their error (here a 0.2 rad
    3rd-order one over a third of the image) is clipping's, not the projector's, and must not
    be removed from the others: the estimate uses the unclipped pixels only (an estimate from
    every valid pixel finds 0.06 rad, which a forced correction would subtract everywhere)."""
    from hdrfringe.core.captures import FringeSet
    from hdrfringe.core.phase import PhaseResult

    rng = np.random.default_rng(5)
    theta = _surface((300, 400))
    clipped = np.zeros(theta.shape, bool)
    clipped[:, :130] = True
    phi = np.mod(theta + rng.normal(0, 0.02, theta.shape), TWO_PI)
    phi[clipped] = np.mod(phi[clipped] + 0.2 * np.sin(3 * theta[clipped]), TWO_PI)
    ones = np.ones(theta.shape)
    res = PhaseResult(phi, ones, ones, ones, clipped.astype(np.uint8), np.ones(theta.shape, bool))
    fs = FringeSet("s", FringeSpec("sinusoidal", 3, 22.0), (0, 1, 2))
    out, summary = compensate_sets([fs], {"s": res}, "auto")
    assert summary["sets"]["s"]["applied"] is False and out["s"] is res
    out, summary = compensate_sets([fs], {"s": res}, 2)  # forced: applied, but ~0
    change = _wrap(out["s"].wrapped_phase - phi)[~clipped]
    assert summary["sets"]["s"]["applied"] and np.abs(change).max() < 0.005
    everything = estimate_harmonic_error(phi, 3, mask=res.valid)
    assert everything.sin[0] > 0.04  # measured 0.061: what a forced correction would remove


def test_significance_needs_both_the_standard_errors_and_the_floor() -> None:
    e = HarmonicError(3, (3,), (0.01,), (0.0,), (1e-3,), (1e-3,), 5, 0.02, 15.0)
    assert json.loads(json.dumps(e.summary()))["significant"] is True  # 10 SE, 0.007 rad RMS
    assert not HarmonicError(3, (3,), (0.01,), (0.0,), (3e-3,), (3e-3,)).significant  # 3.3 SE
    assert not HarmonicError(3, (3,), (1e-3,), (0.0,), (1e-5,), (1e-5,)).significant  # < floor
    assert e.summary()["orders"] == [3]


# --- the command line -----------------------------------------------------------------------


@pytest.fixture(scope="module")
def gamma_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A capture folder of the gamma-mismatched rig: a one-period and a 64 px 3-step set."""
    from hdrfringe.io.captures import write_capture_folder
    from hdrfringe.rig.scenes import glossy
    from hdrfringe.rig.simulated import CameraModel, SimulatedRig

    rig = SimulatedRig(
        glossy(specular=0.0), camera=CameraModel(width=160, height=120), gamma_precompensation=1.0
    )
    specs = [FringeSpec("sinusoidal", 3, 1024.0), FringeSpec("sinusoidal", 3, 64.0)]
    frames = [f for s in specs for f in s.frames()]
    path = tmp_path_factory.mktemp("harmonics") / "caps"
    write_capture_folder(path, Captures(frames, rig.capture(frames), 8, projector=rig.projector))
    return path


def test_cli_phase_and_measure_record_the_estimate(gamma_folder: Path, tmp_path: Path) -> None:
    res = run_cli("phase", str(gamma_folder), "-o", str(tmp_path / "p"), "--harmonics", "auto")
    assert res.returncode == 0, res.stderr
    assert "harmonics s3_p64_v_i40_g255: removed" in res.stdout
    summary = json.loads((tmp_path / "p" / "phase_summary.json").read_text())
    entry = summary["harmonics"]["sets"]["s3_p64_v_i40_g255"]
    assert entry["applied"] and entry["orders"][0] == 3 and entry["rms_rad"] > 0.1
    res = run_cli("measure", str(gamma_folder), "-o", str(tmp_path / "m"), "--harmonics", "2")
    assert res.returncode == 0, res.stderr
    metrics = json.loads((tmp_path / "m" / "metrics.json").read_text())
    assert metrics["harmonics"]["mode"] == "2"
    assert metrics["harmonics"]["sets"]["s3_p64_v_i40_g255"]["orders"] == [3, 6]
    res = run_cli("phase", str(gamma_folder), "-o", str(tmp_path / "q"))
    assert res.returncode == 0 and "harmonics" not in res.stdout
    assert "harmonics" not in json.loads((tmp_path / "q" / "phase_summary.json").read_text())


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["phase", "--harmonics", "yes"], "--harmonics 'yes' is unknown; give off, auto"),
        (["phase", "--harmonics", "auto", "--saturated", "exclude"], "--saturated exclude"),
        (["measure", "--harmonics", "auto", "--strategy", "tolerant"], "--strategy tolerant"),
    ],
)
def test_cli_refuses_bad_combinations(
    gamma_folder: Path, tmp_path: Path, args: list[str], message: str
) -> None:
    out = tmp_path / "out"
    res = run_cli(args[0], str(gamma_folder), "-o", str(out), *args[1:])
    assert res.returncode == 2, res.stdout + res.stderr
    assert message in res.stderr + res.stdout and "Traceback" not in res.stderr
    assert not out.exists()
