"""Thesis Ch. 5 (LPA) and Ch. 6 (DPA) trends on the quick grid of ``hdrfringe reproduce all``.

The run is shared with test_reproduce (the ``quick_run`` fixture); its sweeps are the white
plate under 600 lx (Sec. 5.2.1, three patterns), the checkerboard with the aperture opened for
its black squares (Sec. 5.2.2 / 6.2, sinusoidal 4-step) and the white plate with the 4-step
pattern (Sec. 6.2).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.reproduce import adaptive_report
from hdrfringe.reproduce.adaptive import SweepRig, experiments
from hdrfringe.reproduce.ch4 import QUICK_SETUP, PlateSweep, pattern_spec
from hdrfringe.reproduce.engine import open_results

pytestmark = pytest.mark.xdist_group("dask-cluster")


def _tables(out: Path) -> dict:
    return json.loads((out / "tables.json").read_text())["adaptive"]


def test_table_5_1_lpa_matches_the_tradeoff_and_beats_migl_255(quick_run) -> None:
    """White plate, 600 lx, pitch 6: LPA S=5 below the RMSE at MIGL 255 and within 15 % of the
    uniform trade-off for the 3-step patterns (Table 5.1's pattern)."""
    for row in _tables(quick_run)["table_5_1"]:
        lpa, at255, tradeoff = row["ours"]
        assert tradeoff < at255, row
        if row["pattern"] != "triangular-2":  # 2-step: noisier, the thesis's gap was 7 %
            assert lpa < at255 and lpa <= 1.15 * tradeoff, row
        assert 190 <= row["tradeoff_migl"] < 255


def test_fig_5_6_error_is_flat_over_the_lpa_steps(quick_run) -> None:
    """Pixels composed from each LPA step have about the same RMSE (thesis: within ~0.05 mm
    for the 3-step patterns), and every measured pixel comes from one step."""
    plate = open_results(quick_run / "ch5_plate.zarr")
    total = plate["level_fraction"].sum("index_migl")
    np.testing.assert_allclose(total.values, 1.0, atol=1e-9)
    for pattern in ("sinusoidal-3", "triangular-3"):
        lv = adaptive_report.pooled_levels(plate, pattern, 6)
        used = lv["fraction"] >= 0.02
        assert used.sum() >= 4  # LPA spread the pixels over several MIGLs
        assert np.ptp(lv["rmse"][used]) < 0.05, (pattern, lv)


def test_table_5_2_lpa_beats_the_uniform_tradeoff_on_the_checkerboard(quick_run) -> None:
    rows = {r["method"]: r for r in _tables(quick_run)["table_5_2"]}
    _, rmse_u, std_u = rows["uniform"]["ours"]
    for s in (1, 2, 3, 5, 10, 15):
        _, rmse, std = rows[f"lpa-{s}"]["ours"]
        assert rmse < rmse_u and std < std_u, s
    sets = [rows[f"lpa-{s}"]["ours"][0] for s in (1, 2, 3, 5, 10, 15, 20, 30, 45)]
    assert sets == sorted(sets, reverse=True) and sets[-1] < sets[0] / 20
    assert rows["uniform"]["tradeoff_migl"] < 200  # the white squares need a low MIGL


def test_large_lpa_steps_lose_snr_at_large_pitch(quick_run) -> None:
    """Fig. 5.7: at pitches of 14 px and more, S = 30 and 45 give a higher error std and RMSE
    than S <= 5 (each pixel lands further below its own unsaturation MIGL).

    S = 10..45 coincide on this board: the white squares unsaturate between MIGL 85 and 80,
    and every one of these steps reaches 75 from 255 (255 - 75 = 180 is a multiple of each),
    so they compose the white squares from the same set (docs/reproduction.md)."""
    board = open_results(quick_run / "checkerboard.zarr").isel(pattern=0).mean("depth_mm")
    small = [f"lpa-{s}" for s in (1, 2, 3, 5)]
    for pitch in board["pitch"].values[board["pitch"].values >= 14]:
        for var in ("std_mm", "rmse_mm"):
            c = board[var].sel(pitch=pitch)
            large = c.sel(strategy=["lpa-30", "lpa-45"]).values
            assert large.min() > c.sel(strategy=small).values.max(), (pitch, var)


def test_dpa_is_within_5_percent_of_lpa_15(quick_run) -> None:
    """Ch. 6: DPA at 10 % and 20 % matches LPA S=15 on the checkerboard (Fig. 6.4b) and on the
    white plate (Table 6.1), and 20 % needs no more sets than 10 %."""
    for store in ("checkerboard.zarr", "ch6_plate.zarr"):
        ds = open_results(quick_run / store).isel(pattern=0).mean("depth_mm")
        for pitch in ds["pitch"].values:
            c = ds.sel(pitch=pitch)
            ref = float(c["rmse_mm"].sel(strategy="lpa-15"))
            for t in ("dpa-10", "dpa-20"):
                assert abs(float(c["rmse_mm"].sel(strategy=t)) / ref - 1) < 0.05, (store, pitch)
            assert float(c["sets"].sel(strategy="dpa-20")) <= float(
                c["sets"].sel(strategy="dpa-10")
            )
    t61 = {r["method"]: r["ours"] for r in _tables(quick_run)["table_6_1"]}
    assert t61["dpa-20"][0] <= t61["lpa-20"][0]  # fewer sets than LPA S=20 (Table 6.1)


def test_cdfs_and_the_correction_are_reported(quick_run) -> None:
    board = open_results(quick_run / "checkerboard.zarr")
    cell = board.sel(pitch=8).isel(pattern=0, depth_mm=1)
    actual = cell["cdf_actual"].values
    assert np.all(np.diff(actual) >= 0) and actual[-1] == pytest.approx(1.0)
    final = cell["cdf_final"].sel(strategy="dpa-10").values
    assert np.all(np.diff(final) >= -1e-12) and final[-1] > 0.99
    assert np.isnan(cell["cdf_final"].sel(strategy="lpa-15").values).all()
    corr = _tables(quick_run)["dpa_correction"]
    assert corr["rmse_after_dn"] < corr["rmse_before_dn"]
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
