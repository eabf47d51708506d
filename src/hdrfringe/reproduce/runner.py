"""``hdrfringe reproduce``: run the thesis's experiments as resumable sweeps and report them.

An output folder holds one Zarr store per sweep (``ch4.zarr``, ``ch4_simulation.zarr``), the
figures, ``tables.json`` and ``report.md`` / ``report.html``, and a marker ``reproduce.json``
(what was run, with which grid). Rerunning into the same folder resumes the stores and
regenerates the report; a folder that is not a reproduction is refused unless ``force``.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from hdrfringe import __version__
from hdrfringe.errors import InputError, OutputExistsError

MARKER = "reproduce.json"
CHAPTERS: tuple[str, ...] = ("ch4",)


def _check_folder(out: Path, force: bool, quick: bool) -> None:
    if out.exists() and not out.is_dir():
        raise InputError(f"{out} is a file; give a folder for the reproduction (-o)")
    marker = out / MARKER
    if out.is_dir() and any(out.iterdir()) and not marker.is_file() and not force:
        raise OutputExistsError(
            f"{out} exists and is not a reproduction folder (no {MARKER}); choose another "
            "folder or pass --force to write into it"
        )
    if marker.is_file():
        try:
            before = json.loads(marker.read_text(encoding="utf-8")).get("quick")
        except (OSError, ValueError, AttributeError):
            before = None
        if before is not None and bool(before) != quick:
            grids = {True: "--quick", False: "the full grid"}
            raise InputError(
                f"{out} holds a reproduction on {grids[bool(before)]}; rerun with the same "
                "grid to resume it, or use another folder (-o)"
            )


def _ch4(
    out: Path, quick: bool, run: Callable[..., Any], timings: dict[str, float]
) -> dict[str, Any]:
    from hdrfringe.reproduce import ch4, ch4_report

    setup = ch4.QUICK_SETUP if quick else ch4.Ch4Setup()
    t0 = time.perf_counter()
    ds = run(out / "ch4.zarr", ch4.ch4_grid(quick), ch4.ch4_task, {"setup": setup.to_dict()})
    timings["ch4_sweep_s"] = time.perf_counter() - t0
    sim_grid = ch4.ch4_simulation_grid(quick)
    levels = {v.name: v.extra_dims for v in sim_grid.variables}
    t0 = time.perf_counter()
    sim = run(
        out / "ch4_simulation.zarr",
        sim_grid,
        ch4.ch4_simulation_task,
        {
            "setup": setup.to_dict(),
            "added_lux": list(levels["rmse_light_mm"]["added_lux"]),
            "noise_sigma": list(levels["rmse_noise_mm"]["noise_sigma"]),
            "calibration_depths_mm": list(sim_grid.dims["depth_mm"]),
        },
    )
    timings["ch4_simulation_s"] = time.perf_counter() - t0
    figs = ch4_report.figures(ds, sim, out / "figures")
    return {
        "tables": ch4_report.tables_markdown(ds, sim),
        "differences": ch4_report.differences_markdown(ds, sim),
        "figures": figs,
        "data": {
            "table_4_1": ch4_report.table_4_1(sim),
            "table_4_2": ch4_report.table_4_2(sim),
            "table_4_3": ch4_report.table_4_3(ds),
        },
        "measurements": int(ds["rmse_mm"].size),
    }


def reproduce(
    chapters: Sequence[str],
    out: Path,
    *,
    quick: bool = False,
    scheduler: str | None = None,
    n_workers: int | None = None,
    progress: bool = True,
    force: bool = False,
) -> dict[str, Any]:
    """Run the experiments of ``chapters`` into ``out`` and write the report; return its data.

    Parameters
    ----------
    chapters : sequence of {"ch4"}
    out : Path
        Reproduction folder (created; resumed when it holds an earlier run).
    quick : bool
        The reduced grid (tests and a first look; minutes on two cores).
    scheduler : str, optional
        Address of a dask scheduler; default a local cluster of ``n_workers`` processes.
    """
    from hdrfringe.reproduce.engine import run_sweep

    unknown = [c for c in chapters if c not in CHAPTERS]
    if unknown or not chapters:
        raise InputError(
            f"unknown chapter(s) {unknown or chapters}; use {', '.join(CHAPTERS)} or all"
        )
    _check_folder(out, force, quick)
    out.mkdir(parents=True, exist_ok=True)
    (out / MARKER).write_text(
        json.dumps({"hdrfringe": __version__, "quick": quick, "chapters": list(chapters)}) + "\n",
        encoding="utf-8",
    )

    def run(store: Path, grid: Any, func: Any, params: dict[str, Any]) -> Any:
        return run_sweep(
            store, grid, func, params, scheduler=scheduler, n_workers=n_workers, progress=progress
        )

    timings: dict[str, float] = {}
    results: dict[str, Any] = {}
    if "ch4" in chapters:
        results["ch4"] = _ch4(out, quick, run, timings)
    results["timings_s"] = timings
    _write_report(out, results, quick)
    return results


def _write_report(out: Path, results: dict[str, Any], quick: bool) -> None:
    data = {k: v.get("data", v) if isinstance(v, dict) else v for k, v in results.items()}
    (out / "tables.json").write_text(json.dumps(data, indent=1, default=float) + "\n", "utf-8")
    lines = [
        "# hdrfringe: reproduction of the thesis's experiments",
        "",
        f"hdrfringe {__version__}; grid: {'quick (reduced)' if quick else 'full (thesis)'}; "
        "virtual rig. Ratios are ours / thesis.",
    ]
    ch4 = results.get("ch4")
    if ch4:
        t = results["timings_s"]
        lines += [
            "",
            "## Chapter 4: uniform adjustment of the MIGL",
            "",
            f"{ch4['measurements']} measurements (Sec. 4.2) in {t['ch4_sweep_s']:.0f} s, "
            f"Sec. 4.3 simulations in {t['ch4_simulation_s']:.0f} s (this run: cells already "
            "stored are not recomputed, so a resumed run times only the rest).",
            "",
            "### Table 4.1: simulated added light, sinusoidal 3-step, pitch 6",
            "",
            ch4["tables"]["4.1"],
            "",
            "### Table 4.2: 600 lx and added noise, sinusoidal 3-step, pitch 6",
            "",
            ch4["tables"]["4.2"],
            "",
            "### Table 4.3: pitch 6, MIGL 255 and the trade-off",
            "",
            ch4["tables"]["4.3"],
            "",
            "### Differences from the thesis",
            "",
            ch4["differences"],
            "",
            "### Figures",
            "",
        ]
        lines += [f"![{f}](figures/{f})" for f in ch4["figures"]]
    import markdown

    text = "\n".join(lines) + "\n"
    (out / "report.md").write_text(text, encoding="utf-8")
    (out / "report.html").write_text(
        "<!doctype html><html><head><meta charset='utf-8'><title>hdrfringe reproduction</title>"
        "<style>table{border-collapse:collapse}td,th{border:1px solid #999;padding:2px 6px}"
        "img{max-width:100%}</style></head><body>\n"
        + markdown.markdown(text, extensions=["tables"])
        + "\n</body></html>\n",
        encoding="utf-8",
    )
