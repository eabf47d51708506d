"""Thesis Ch. 5 (LPA) and Ch. 6 (DPA) trends on the quick grid of ``hdrfringe reproduce all``.

The run is shared with test_reproduce (the ``quick_run`` fixture); its sweeps are the white
plate under 600 lx (Sec. 5.2.1, three patterns), the checkerboard with the aperture opened for
its black squares (Sec. 5.2.2 / 6.2, sinusoidal 4-step) and the white plate with the 4-step
pattern (Sec. 6.2).
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pytest

import reproduce_checks as checks
from hdrfringe.core.saturation.estimate import CorrectionPolynomial
from hdrfringe_thesis.adaptive import SweepRig, experiments
from hdrfringe_thesis.ch4 import QUICK_SETUP, PlateSweep, pattern_spec
from hdrfringe_thesis.engine import open_results

pytestmark = pytest.mark.xdist_group("dask-cluster")


def _tables(out: Path) -> dict:
    return json.loads((out / "tables.json").read_text())["adaptive"]


def test_table_5_1_lpa_beats_every_uniform_set_in_error_std(quick_run) -> None:
    """White plate, 600 lx: LPA S=5's error std is at least 1 % below that of every single set,
    for the 3-step patterns at every pitch (Table 5.1: LPA matches the trade-off and beats MIGL
    255). The sets are those of the same sweep (MIGL 255..190, paired: same captures) and of
    the independent Ch. 4 sweep (MIGL 255..105 over the same depths, other noise draws, the
    fast capture path). Measured: LPA is 1.7-5.9 % below the best set of its own sweep and
    3.5-7.4 % below the Ch. 4 sweep's; the two sweeps, with independent noise, agree within
    0.5 % at MIGL 225 (the 1 % margin is twice that).

    The former check, ``lpa <= 1.15 * trade-off`` in RMSE, also passed a single set at any MIGL
    from 135 to 235 (the -0.16 mm bias of the linear model dominates the RMSE); this one
    rejects every such set (test_reproduce_broken). The 2-step pattern is left out: there LPA
    is worse than the trade-off (ours 0.53 against 0.44 mm std at pitch 6; the thesis 1.10
    against 1.03 mm RMSE), its per-depth std scattering by up to 0.5 mm."""
    for row in _tables(quick_run)["table_5_1"]:
        _, at255, tradeoff = row["ours"]
        assert tradeoff < at255 and 190 <= row["tradeoff_migl"] < 255, row
    for pattern, pitch in itertools.product(("sinusoidal-3", "triangular-3"), (6, 12, 20)):
        lpa_std, uniform = checks.lpa_and_uniform_std(quick_run, pattern, pitch)
        assert not checks.check_lpa_beats_every_uniform_set(lpa_std, uniform, 0.01), (
            pattern,
            pitch,
        )


def test_fig_5_6_error_is_flat_over_the_lpa_steps(quick_run) -> None:
    """Fig. 5.6 in error std: the pixels LPA S=5 composes from each of its MIGLs (those holding
    at least 2 % of the pixels, at least 4 of them) have about the same error std, per depth
    and averaged over the depths (:func:`~reproduce_checks.level_std`): the largest
    below 1.3 x the smallest, for the 3-step patterns at pitches 6, 12 and 20; and every
    measured pixel comes from one step. Measured max / min: sinusoidal 1.05, 1.08, 1.10,
    triangular 1.17, 1.20, 1.17.

    An LPA that tests saturation on the first of the N shifts only composes about 70 % of the
    pixels from MIGL 255 with others of their shifts saturated: their std is 1.86 x that of
    the other steps (triangular 3-step, pitch 6) and this check rejects it
    (test_reproduce_broken). The former check, the steps' RMSE pooled over depth within
    0.05 mm of each other (the thesis's "within ~0.05 mm"), accepted it (0.036 mm): the linear
    model's bias, -0.16 to +0.08 mm between depths, is most of each step's pooled RMSE.
    The 2-step pattern is left out, as in Table 5.1: its steps' std spreads 2.1-2.9 x (its
    phase error is not noise-limited, see test_table_5_1_lpa_beats_every_uniform_set)."""
    plate = open_results(quick_run / "ch5_plate.zarr")
    total = plate["level_fraction"].sum("index_migl")
    np.testing.assert_allclose(total.values, 1.0, atol=1e-9)
    for pattern, pitch in itertools.product(("sinusoidal-3", "triangular-3"), (6, 12, 20)):
        levels = checks.level_std(plate, pattern, pitch, min_fraction=0.02)
        assert len(levels) >= 4  # LPA spread the pixels over several MIGLs
        assert not checks.check_levels_flat(levels, 1.3), (pattern, pitch, levels)


def test_table_5_2_lpa_beats_the_uniform_tradeoff_on_the_checkerboard(quick_run) -> None:
    """Table 5.2 (checkerboard, pitch 8): LPA with S = 1..15 has an error std at least 15 %
    below the uniform trade-off's (measured 0.0748-0.0777 against 0.0988 mm at MIGL 115:
    21-24 % below; the thesis 0.47-0.48 against 0.83 mm, 42-43 %); set counts fall with S.

    The RMSEs (0.177-0.178 against 0.188 mm) differ by 6 % only: the linear model's bias,
    -0.160 mm for every method, is most of them. The former check (RMSE and std merely below
    the trade-off's) passed an LPA whose std is 15 % larger; this one rejects it
    (test_reproduce_broken)."""
    rows = {r["method"]: r for r in _tables(quick_run)["table_5_2"]}
    _, rmse_u, std_u = rows["uniform"]["ours"]
    tradeoff = {f"uniform trade-off, MIGL {rows['uniform']['tradeoff_migl']:g}": std_u}
    for s in (1, 2, 3, 5, 10, 15):
        _, rmse, std = rows[f"lpa-{s}"]["ours"]
        assert rmse < rmse_u, s
        assert not checks.check_lpa_beats_every_uniform_set(std, tradeoff, 0.15), s
    sets = [rows[f"lpa-{s}"]["ours"][0] for s in (1, 2, 3, 5, 10, 15, 20, 30, 45)]
    assert sets == sorted(sets, reverse=True) and sets[-1] < sets[0] / 20
    assert rows["uniform"]["tradeoff_migl"] < 200  # the white squares need a low MIGL


def test_lpa_set_counts_follow_from_step_1(quick_run) -> None:
    """Tables 5.2 / 6.1 / 6.2: in every cell of both Ch. 6 sweeps, LPA step S captures
    ``ceil((n1 - 1) / S) + 1`` sets within one, n1 being step 1's count (step 1 stops at the
    first MIGL by which every pixel has been unsaturated; step S at the first of its MIGLs at or
    below it). A count that merely falls as S grows (the former check) is also what an LPA
    that does not stop once every pixel is found would give (test_reproduce_broken: it fails
    this check). Measured: 73 of the 108 counts (S >= 2) are the prediction, the other 35 one
    set off, either way (noise unsaturates a pixel at one MIGL and saturates it again below)."""
    for store in ("checkerboard", "ch6_plate"):
        ds = open_results(quick_run / f"{store}.zarr")
        steps = [int(str(m)[4:]) for m in ds["strategy"].values if str(m).startswith("lpa-")]
        sets = {s: ds["sets"].sel(strategy=f"lpa-{s}").values.ravel().tolist() for s in steps}
        assert not checks.check_lpa_set_counts(sets), store


def test_large_lpa_steps_lose_snr_at_large_pitch(quick_run) -> None:
    """Fig. 5.7: at pitches of 14 px and more, S = 30 and 45 give a higher error std and RMSE
    than S <= 5 (each pixel lands further below its own unsaturation MIGL).

    S = 10..45 coincide on this board: the white squares unsaturate between MIGL 85 and 80,
    and every one of these steps reaches 75 from 255 (255 - 75 = 180 is a multiple of each),
    so they compose the white squares from the same set (research/docs/reproduction.md)."""
    board = open_results(quick_run / "checkerboard.zarr").isel(pattern=0).mean("depth_mm")
    small = [f"lpa-{s}" for s in (1, 2, 3, 5)]
    for pitch in board["pitch"].values[board["pitch"].values >= 14]:
        for var in ("std_mm", "rmse_mm"):
            c = board[var].sel(pitch=pitch)
            large = c.sel(strategy=["lpa-30", "lpa-45"]).values
            assert large.min() > c.sel(strategy=small).values.max(), (pitch, var)


def test_dpa_matches_lpa_15_in_error_std(quick_run) -> None:
    """Ch. 6 (Fig. 6.5, Tables 6.1-6.2: DPA's std equals LPA S=15's, 0.25/0.25 and 0.56/0.56
    mm): DPA 10 % and 20 % have the error std of LPA S=15 within 5 % at every pitch of the
    checkerboard and the white plate, and 20 % needs no more sets than 10 %.

    Measured DPA / LPA S=15 std: 0.973-0.985 on the checkerboard, 0.991-1.026 on the plate;
    a method's std varies by 0.1-1.8 % between the depths of one pitch. The former check
    (RMSE within 5 %) passed a DPA whose std is 10 % larger (the common -0.16 mm bias hides
    it: RMSE +1.3-3.9 %); this one rejects it (test_reproduce_broken)."""
    lpa15 = checks.method_std_by_cell(quick_run, "lpa-15")
    for method in ("dpa-10", "dpa-20"):
        dpa = checks.method_std_by_cell(quick_run, method)
        assert not checks.check_dpa_matches_lpa_15(dpa, lpa15, 0.05), method
    for store in ("checkerboard.zarr", "ch6_plate.zarr"):
        ds = open_results(quick_run / store).isel(pattern=0).mean("depth_mm")
        for pitch in ds["pitch"].values:
            sets = ds["sets"].sel(pitch=pitch)
            assert float(sets.sel(strategy="dpa-20")) <= float(sets.sel(strategy="dpa-10"))
    t61 = {r["method"]: r["ours"] for r in _tables(quick_run)["table_6_1"]}
    assert t61["dpa-20"][0] <= t61["lpa-20"][0]  # fewer sets than LPA S=20 (Table 6.1)


def test_dpa_set_counts_fall_with_pitch_and_exceed_lpa_15_on_the_checkerboard(quick_run) -> None:
    """DPA's set counts against the thesis (Fig. 6.6, Tables 6.1-6.2).

    Holds on our rig and asserted: on the checkerboard DPA 10 % and 20 % need fewer sets as
    the pitch grows (quick grid, mean over depth: 78, 69, 66 sets at 8, 14, 20 px for 10 %)
    and more than LPA S=15 at every pitch, by a ratio that falls with the pitch (6.0, 4.9, 4.7:
    the thesis's "approaches LPA S=15"); on the 600 lx white plate DPA 20 % needs fewer sets
    than LPA S=20 (Table 6.1: ours 0.75 of it on the quick grid, 0.90 on the full one, the
    thesis 7.06 / 9.81 = 0.72).

    Does not hold (research/docs/reproduction.md, "Tests"; measured over every pitch 5..20 at 18 mm
    on the quick camera): the checkerboard's DPA / LPA S=15 ratio is 5.3 (thesis 29.33 / 14 = 2.1)
    and 4.6 even at 19-20 px; the plate's DPA count does not fall with the pitch (4-7 sets,
    rising: the plate saturates more at larger pitches, Fig. 4.5); DPA 10 % takes 0.67 of
    LPA S=10's sets, not "comparable"."""
    board = open_results(quick_run / "checkerboard.zarr").isel(pattern=0).mean("depth_mm")
    pitches = board["pitch"].values.tolist()
    lpa15 = board["sets"].sel(strategy="lpa-15").values
    for method in ("dpa-10", "dpa-20"):
        sets = board["sets"].sel(strategy=method).values
        assert not checks.check_dpa_sets_fall_with_pitch(sets, pitches), method
        ratio = sets / lpa15
        assert np.all(ratio > 1) and ratio[-1] < ratio[0], (method, ratio)
    t61 = {r["method"]: r["ours"][0] for r in _tables(quick_run)["table_6_1"]}
    assert t61["dpa-20"] < 0.95 * t61["lpa-20"], t61


def test_actual_cdf_is_bounded_by_the_uniform_sets(quick_run) -> None:
    """Fig. 6.3's actual CDF (from LPA step 1's index image) against an independent count:
    a pixel unsaturated in the uniform set at MIGL m has its index at m or above, so
    ``CDF(m) >= 1 - saturated(m) / saturated(255)`` at every uniform MIGL of every cell of both
    sweeps (the same captures: :class:`SweepRig`). Measured shortfall at most 0.0018 (the image
    border, left out of the saturated fractions); a CDF read 10 gray levels too high falls
    0.33-0.88 short (test_reproduce_broken). (The former check, that the CDF never falls, holds
    for any cumulative sum.)"""
    for store in ("checkerboard.zarr", "ch6_plate.zarr"):
        ds = open_results(quick_run / store).isel(pattern=0)
        migls = ds["uniform_migl"].values
        for pitch, depth in itertools.product(ds["pitch"].values, ds["depth_mm"].values):
            cell = ds.sel(pitch=pitch, depth_mm=depth)
            cdf = cell["cdf_actual"].sel(cdf_migl=migls).values
            sat = cell["saturated_fraction"].values
            assert not checks.check_actual_cdf_bounds(cdf, sat, 0.005), (store, pitch, depth)
    cell = open_results(quick_run / "checkerboard.zarr").sel(pitch=8).isel(pattern=0, depth_mm=1)
    final = cell["cdf_final"].sel(strategy="dpa-10").values
    assert final[-1] > 0.99
    assert np.isnan(cell["cdf_final"].sel(strategy="lpa-15").values).all()


def test_dpa_correction_generalises_to_a_held_out_plate_position(quick_run) -> None:
    """Sec. 6.1.2: the reproduction's correction polynomial (trained at 26 mm, pitch 20)
    applied to the saturated pixels of a plate position it never saw (14 mm): the Eq. 6.2
    estimate's RMSE falls by at least 5 % and ends within 5 % of a polynomial fitted to those
    pixels themselves. Measured: 4.53 -> 4.11 DN (-9.3 %), own fit 4.01 DN (+2.3 %). The
    former check (training RMSE falls) also passes an order-6 polynomial fitted to 10 pixels,
    whose held-out RMSE is 18.9 DN (test_reproduce_broken).

    Our estimate's error is 4.5 DN before correction against the thesis's 71.05 gray levels:
    the virtual projector's gamma is pre-compensated exactly (issue 15)."""
    poly = CorrectionPolynomial.load(quick_run / "dpa_correction.json")
    est, true = checks.held_out_samples()
    before, after, own = checks.correction_rmse(poly, est, true)
    assert not checks.check_correction_generalises(before, after, own, 0.05, 0.05)
    corr = _tables(quick_run)["dpa_correction"]
    assert corr["thesis_before_after_gray_levels"] == [71.05, 2.99]
    report = (quick_run / "report.md").read_text()
    for table in ("Table 5.1", "Table 5.2", "Table 6.1", "Table 6.2", "71.05"):
        assert table in report
    figs = {p.name for p in (quick_run / "figures").glob("fig[56]_*.png")}
    assert len(figs) == 14 and "fig6_3_cdf.png" in figs
    assert (quick_run / "dpa_correction.json").is_file()


def test_sweep_rig_serves_each_migl_once_and_refuses_other_sets() -> None:
    exp = experiments(quick=True)["checkerboard"]
    setup = exp.setup(QUICK_SETUP)
    spec = pattern_spec("sinusoidal-4", 8, setup.imin)
    rig = SweepRig(PlateSweep(18.0, setup, spec, scene=exp.scene_at(18.0)), setup, 0.0, ("t",))
    a = rig.capture(spec.with_migl(200.0).frames())
    b = rig.capture(spec.with_migl(200.0).frames())
    assert a is b and rig.sets_rendered == 1
    assert (a == 255).any()  # the white squares saturate at 200 with the opened aperture
    from hdrfringe.errors import InputError

    with pytest.raises(InputError, match="holds"):
        rig.capture(pattern_spec("sinusoidal-4", 10, setup.imin).frames())
