"""``hdrfringe reproduce all --quick`` end to end: the thesis's Ch. 4 trends on the quick grid,
resumption, and the report beside the thesis's tables (Ch. 5 and 6: test_reproduce_adaptive)."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from hdrfringe.reproduce.engine import RUNTIME_ATTRS, open_results, sweep_status
from tests.conftest import run_cli

# Tests that start dask clusters run in one xdist worker (make test: --dist loadgroup), so
# at most one local cluster runs at a time on the two cores.
pytestmark = pytest.mark.xdist_group("dask-cluster")


def _depth_mean(out: Path) -> xr.DataArray:
    return open_results(out / "ch4.zarr")["rmse_mm"].mean("depth_mm")


def test_600_lux_has_an_interior_minimum_and_0_lux_does_not_rise_above_205(quick_run) -> None:
    mean = _depth_mean(quick_run)
    for pattern in mean["pattern"].values:
        lit = mean.sel(pattern=pattern, lux=600.0, pitch=6)
        best = float(lit.min())
        assert float(lit.sel(migl=255.0)) > 1.05 * best, pattern
        assert float(lit.sel(migl=105.0)) > 1.005 * best, pattern
        dark = mean.sel(pattern=pattern, lux=0.0).mean("pitch")
        high = dark.where(dark["migl"] >= 205, drop=True).sortby("migl")
        # rising MIGL never raises the RMSE beyond 1 % (noise between cells)
        assert np.all(np.diff(high.values) <= 0.01 * high.values[:-1]), pattern


def test_smaller_pitch_saturates_fewer_pixels(quick_run) -> None:
    """Fig. 4.5: at 600 lx and MIGL 255 the saturated share grows with the pitch."""
    sat = open_results(quick_run / "ch4.zarr")["saturated_fraction"]
    total = sat.sel(lux=600.0, migl=255.0).sum("saturated_shifts").mean("depth_mm")
    for pattern in total["pattern"].values:
        v = total.sel(pattern=pattern).sortby("pitch").values
        assert v[0] < v[-1] and np.all(np.diff(v) > -0.01), (pattern, v)
    assert float(sat.sel(lux=0.0).max()) == 0.0


def test_tables_follow_the_thesis_trends(quick_run) -> None:
    tables = json.loads((quick_run / "tables.json").read_text())["ch4"]
    t41 = tables["table_4_1"]
    migls = [r["ours"][0] for r in t41]
    assert migls == sorted(migls, reverse=True) and migls[0] > migls[-1]  # Table 4.1
    assert all(r["ours"][2] <= r["ours"][1] for r in t41)  # the trade-off beats MIGL 255
    rmse = [r["ours"][1] for r in tables["table_4_2"]]
    assert all(b > a for a, b in itertools.pairwise(rmse))  # Table 4.2
    for r in tables["table_4_3"]:  # Table 4.3: trade-off under 600 lx within 25 % of 0 lx
        _, dark, lit255, lit_trade = r["ours"]
        assert lit_trade < lit255 and lit_trade < 1.25 * dark
    report = (quick_run / "report.md").read_text()
    for table in ("Table 4.1", "Table 4.2", "Table 4.3"):
        assert table in report
    assert (quick_run / "report.html").is_file()
    assert {"fig4_5_saturation_by_pitch.png", "fig4_13_pitch6.png"} <= {
        p.name for p in (quick_run / "figures").glob("fig4_*.png")
    }
    assert len(list((quick_run / "figures").glob("fig4_*.png"))) == 11


def test_rerun_resumes_and_computes_nothing(quick_run) -> None:
    stores = ("ch4.zarr", "ch4_simulation.zarr", "ch5_plate.zarr", "checkerboard.zarr")
    before = {s: open_results(quick_run / s) for s in stores}
    assert all(sweep_status(quick_run / s).complete for s in stores)
    res = run_cli("reproduce", "all", "--quick", "-o", str(quick_run), "--workers", "1")
    assert res.returncode == 0, res.stderr
    for s in stores:
        after = open_results(quick_run / s)
        for attr in RUNTIME_ATTRS:
            before[s].attrs.pop(attr, None)
            after.attrs.pop(attr, None)
        xr.testing.assert_identical(before[s], after)


def test_refuses_a_folder_that_is_not_a_reproduction(tmp_path: Path) -> None:
    (tmp_path / "notes.txt").write_text("mine")
    res = run_cli("reproduce", "ch4", "--quick", "-o", str(tmp_path))
    assert res.returncode == 2
    assert "not a reproduction folder" in res.stderr and "Traceback" not in res.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]
    res = run_cli("reproduce", "ch9", "-o", str(tmp_path / "x"))
    assert res.returncode == 2 and "unknown chapter" in res.stderr
    assert not (tmp_path / "x").exists()


def test_refuses_to_mix_the_quick_and_the_full_grid(quick_run) -> None:
    marker = (quick_run / "reproduce.json").read_text()
    res = run_cli("reproduce", "ch4", "-o", str(quick_run))
    assert res.returncode == 2 and "holds a reproduction on --quick" in res.stderr
    assert (quick_run / "reproduce.json").read_text() == marker


_SLOW_FIGURES = """
import sys, time
import hdrfringe.reproduce.adaptive_report as ar
from hdrfringe.cli import app

def slow(*args, **kwargs):  # Ch. 4's figures are rendered by now; stop in Ch. 5-6's
    print("figures", flush=True)
    time.sleep(60)

ar.figures = slow
app(sys.argv[1:], prog_name="hdrfringe")
"""


def test_sigterm_while_rendering_leaves_the_previous_report_untouched(
    quick_run: Path, tmp_path: Path
) -> None:
    """The report (figures, tables, report.md/html) is staged: a run stopped half-way leaves
    the previous one as it was (figures were overwritten one by one in place before, and
    SIGTERM ended the run without cleanup), while the stores stay resumable."""
    import shutil
    import signal
    import subprocess
    import sys

    out = tmp_path / "repro"
    shutil.copytree(quick_run, out)
    report = [out / "figures", out / "tables.json", out / "report.md", out / "report.html"]
    report += sorted((out / "figures").iterdir())
    before = {p: (p.stat().st_ino, p.stat().st_mtime_ns) for p in report}
    driver = tmp_path / "slow_figures.py"
    driver.write_text(_SLOW_FIGURES)
    proc = subprocess.Popen(
        [sys.executable, str(driver), "reproduce", "all", "--quick", "-o", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None and proc.stderr is not None
    assert proc.stdout.readline().strip() == "figures", proc.stderr.read()
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=60) == 143, proc.stderr.read()
    assert {p: (p.stat().st_ino, p.stat().st_mtime_ns) for p in report} == before
    assert [p.name for p in out.iterdir() if p.name.startswith(".")] == []
    assert all(sweep_status(out / s).complete for s in ("ch4.zarr", "checkerboard.zarr"))
