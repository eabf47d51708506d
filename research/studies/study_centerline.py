"""Study: fringe-order failures of the thesis's pipeline in the Table 4.1 simulation.

Run ``.venv/bin/python research/studies/study_centerline.py`` (quick view, a minute on two cores) or
``--full`` (the thesis's 648 x 494 view and 25 plate positions, Table 4.1's cells: about ten
minutes on two idle cores); ``--json PATH`` also writes the results. See
research/docs/reproduction.md, "Fringe-order failures (centerline pipeline)".

For the sinusoidal 3-step set at pitch 6 (thesis Table 4.1) and every plate position, the
Eq. 4.1 added-light simulation of :func:`hdrfringe_thesis.ch4.ch4_modified_block` is run
with both fringe-order modes, over the thesis's 100..900 lx and beyond (1000..1200 lx), every
MIGL of the grid. Printed per added light: the trade-off MIGL, the mean RMSE at MIGL 255 and at
the trade-off (known orders / centerline pipeline) and the fraction of pixels with a wrong
fringe order (mean over positions at MIGL 255; the largest of any cell), and the largest step
between 4-neighbours of the known-order phase at MIGL 255 (below pi: spatial unwrapping cannot
fail, ``ch4.centerline_unwrap``).

Two computations explain the outcome:

* the fringe minimum: per pixel, the smallest noise-free signal of the three shifts at MIGL
  255, 0 lx (percentiles over the measured pixels). Eq. 4.1 adds 0.17 DN per lx to every
  shift, so a pixel is saturated in all three shifts, its phase lost (``atan2(0, 0)``), once
  the added light exceeds ``(255 - minimum) / 0.17`` lx; the printed onsets are that bound;
* the noise study (600 lx plus Gaussian noise of sigma 1..8, Table 4.2), which the sweep keeps
  on known orders: the centerline pipeline's wrong-order fraction there (MIGL 255..195, every
  position, sigma 8, the noisiest).

``--cost`` instead times the quick reproduction's 12 Sec. 4.3 blocks in both modes (CPU
seconds, one process, interleaved, two repeats).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from hdrfringe.core.calibration import measurement_mask
from hdrfringe.rig.modify import lux_to_dn, modify_intensity
from hdrfringe.rig.sensor import sensor_readout
from hdrfringe_thesis import ch4

PATTERN, PITCH = "sinusoidal-3", 6
ADDED_LUX = (*ch4.THESIS_ADDED_LUX, 1000.0, 1100.0, 1200.0)
NOISE_MIGLS = (255.0, 225.0, 195.0)
NOISE_SIGMA = 8.0


def _setup(full: bool) -> tuple[ch4.Ch4Setup, tuple[float, ...], tuple[float, ...]]:
    if full:
        return ch4.Ch4Setup(), ch4.THESIS_MIGLS, ch4.THESIS_DEPTHS_MM
    return ch4.QUICK_SETUP, ch4.QUICK_MIGLS, ch4.QUICK_DEPTHS_MM


def _position(args: tuple[bool, float, tuple[float, ...]]) -> dict[str, Any]:
    """Both modes at one plate position, the fringe minimum and the noise-study orders."""
    full, depth, migls = args
    setup, _, depths = _setup(full)
    out: dict[str, Any] = {"depth_mm": depth, "seconds": {}}
    for mode in ch4.UNWRAP_MODES:
        t0 = time.perf_counter()
        res = ch4.ch4_modified_block(
            PATTERN, PITCH, ADDED_LUX, (), migls, (depth,), setup,
            calibration_depths_mm=depths, unwrap=mode,
        )  # fmt: skip
        out["seconds"][mode] = time.perf_counter() - t0
        out[mode] = {k: v[..., 0].tolist() for k, v in res.items() if k != "rmse_noise_mm"}
    spec = ch4.pattern_spec(PATTERN, PITCH, setup.imin)
    plate = ch4.PlateSweep(depth, setup, spec)
    mask = measurement_mask((setup.height, setup.width), setup.border_px)
    low = plate.signal(255.0).min(axis=0)[mask]
    out["fringe_minimum_dn"] = np.percentile(low, [1, 10, 50, 90, 99]).tolist()
    # the largest 4-neighbour step of the known-order phase at MIGL 255 per added light: below
    # pi, the known orders are the only spatial unwrapping (ch4.centerline_unwrap)
    cam = setup.camera_model()
    shape = plate.rig.image_shape
    normals = ch4.depth_normals(setup, spec, PATTERN, depth, shape)
    imgs = sensor_readout(plate.signal(255.0), cam, normals=normals, dtype=ch4.SWEEP_DTYPE)
    steps = []
    for lux in ADDED_LUX:
        mod = modify_intensity(imgs, cam.bit_depth, lux_to_dn(lux, 8), dtype=ch4.SWEEP_DTYPE)
        known = ch4.orders_from_expected(ch4.sweep_phase(mod, spec), plate.expected_phase)
        steps.append(max(float(np.abs(np.diff(known, axis=a)).max()) for a in (0, 1)))
    out["max_step_rad_255"] = steps
    # the noise study's cells with the centerline pipeline (the sweep keeps known orders there)
    z = ch4.depth_normals(setup, spec, PATTERN, depth, shape, "eq4.1")
    rng = ch4.cell_rng(setup, "centerline", PATTERN, float(PITCH), float(depth))
    zl = rng.standard_normal((1, *shape), dtype=ch4.SWEEP_DTYPE)
    rng_line = ch4.cell_rng(setup, "centerline-eq4.1", PATTERN, float(PITCH), float(depth))
    zl41 = rng_line.standard_normal((1, *shape), dtype=ch4.SWEEP_DTYPE)
    added = lux_to_dn(600.0, cam.bit_depth)
    wrong = []
    for m in NOISE_MIGLS:
        imgs = sensor_readout(plate.signal(m), cam, normals=normals, dtype=ch4.SWEEP_DTYPE)
        line = sensor_readout(plate.centerline_signal(m), cam, normals=zl, dtype=ch4.SWEEP_DTYPE)
        sigma = ch4.SWEEP_DTYPE(NOISE_SIGMA)
        mod = modify_intensity(imgs, cam.bit_depth, added, sigma * z, dtype=ch4.SWEEP_DTYPE)
        seen = modify_intensity(line, cam.bit_depth, added, sigma * zl41, dtype=ch4.SWEEP_DTYPE)
        wrapped = ch4.sweep_phase(mod, spec)
        known = ch4.orders_from_expected(wrapped, plate.expected_phase)
        phase = ch4.centerline_unwrap(wrapped, seen[0], plate.centerline_position, PITCH)
        wrong.append(ch4.order_error_fraction(phase, known, mask))
    out["noise_order_error_fraction"] = wrong
    return out


def _tradeoff(curve: np.ndarray, migls: tuple[float, ...]) -> tuple[float, float]:
    """(MIGL, value) of the lowest mean RMSE: the report's own rule (ch4_report.tradeoff)."""
    import xarray as xr

    from hdrfringe_thesis.ch4_report import tradeoff

    return tradeoff(xr.DataArray(curve, coords={"migl": list(migls)}))


def cost(repeats: int = 2) -> dict[str, list[float]]:
    """CPU seconds of the quick reproduction's Sec. 4.3 blocks (all 12, one process) in each
    mode, interleaved, after one warm-up block per pattern (the calibrations)."""
    import itertools

    grid = ch4.ch4_simulation_grid(quick=True)
    params = {
        "setup": ch4.QUICK_SETUP.to_dict(),
        "added_lux": list(ch4.QUICK_ADDED_LUX),
        "noise_sigma": list(ch4.QUICK_NOISE_SIGMA),
        "calibration_depths_mm": list(ch4.QUICK_DEPTHS_MM),
    }
    blocks = [grid.block_coords(i) for i in itertools.product(*map(range, grid.blocks_shape))]
    for pattern in ch4.PATTERNS:
        ch4.calibrate_pattern(pattern, ch4.SIMULATION_PITCH, ch4.QUICK_SETUP, ch4.QUICK_DEPTHS_MM)
    out: dict[str, list[float]] = {m: [] for m in ch4.UNWRAP_MODES}
    for _ in range(repeats):
        for mode in ch4.UNWRAP_MODES:
            t0 = time.process_time()
            for coords in blocks:
                ch4.ch4_simulation_task(coords, {**params, "unwrap": mode})
            out[mode].append(time.process_time() - t0)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--full", action="store_true", help="thesis view and 25 positions")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument(
        "--migls",
        type=float,
        nargs="+",
        help="only these MIGLs (must include 255; the trade-off is then over these alone)",
    )
    parser.add_argument("--json", type=Path, help="also write the results here")
    parser.add_argument(
        "--cost", action="store_true", help="only time the quick reproduction's blocks"
    )
    args = parser.parse_args(argv)
    if args.cost:
        secs = cost()
        print(
            "quick reproduction, Sec. 4.3 blocks (12), CPU s per repeat: "
            + "; ".join(f"{m} {', '.join(f'{t:.1f}' for t in v)}" for m, v in secs.items())
        )
        return 0
    setup, migls, depths = _setup(args.full)
    if args.migls:
        migls = tuple(sorted({*args.migls, 255.0}, reverse=True))
    t0 = time.perf_counter()
    with ProcessPoolExecutor(args.workers) as pool:
        per = list(pool.map(_position, [(args.full, d, migls) for d in depths]))
    wall = time.perf_counter() - t0
    i255 = migls.index(255.0)
    rows = []
    view = "full" if args.full else "quick"
    print(
        f"{view} view {setup.width}x{setup.height}, {len(depths)} positions, {len(migls)} "
        f"MIGLs; {wall:.0f} s on {args.workers} workers"
    )
    print(
        "lux | trade-off MIGL known/centerline | RMSE 255 (mm) known/centerline | RMSE "
        "trade-off known/centerline | wrong orders at 255 (mean) | max any cell | largest "
        "neighbour step of the known-order phase at 255 (rad)"
    )
    for i, lux in enumerate(ADDED_LUX):
        step = max(p["max_step_rad_255"][i] for p in per)
        rec: dict[str, Any] = {"lux": lux, "max_step_rad_255": step}
        for mode in ch4.UNWRAP_MODES:
            curve = np.mean([p[mode]["rmse_light_mm"][i] for p in per], axis=0)
            t_migl, t_rmse = _tradeoff(curve, migls)
            wrong = np.array([p[mode]["order_error_fraction"][i] for p in per])
            rec[mode] = {
                "tradeoff_migl": t_migl,
                "rmse_255_mm": float(curve[i255]),
                "rmse_tradeoff_mm": t_rmse,
                "wrong_orders_255": float(np.mean(wrong[:, i255])),
                "wrong_orders_max": float(np.nanmax(wrong)) if np.isfinite(wrong).any() else None,
                "positions_without_line": int(np.isnan(wrong).any(axis=1).sum()),
            }
        k, c = rec["known"], rec["centerline"]
        print(f"{lux:5.0f} | {k['tradeoff_migl']:.0f} / {c['tradeoff_migl']:.0f} | "
              f"{k['rmse_255_mm']:.3f} / {c['rmse_255_mm']:.3f} | "
              f"{k['rmse_tradeoff_mm']:.3f} / {c['rmse_tradeoff_mm']:.3f} | "
              f"{100 * c['wrong_orders_255']:.2f} % | {100 * (c['wrong_orders_max'] or 0):.2f} %"
              f" | {step:.2f}"
              + (f" ({c['positions_without_line']} positions: no line)"
                 if c["positions_without_line"] else ""))  # fmt: skip
        rows.append(rec)
    low = np.array([p["fringe_minimum_dn"] for p in per])
    onset = (255.0 - low) / lux_to_dn(1.0, 8)
    print("fringe minimum at MIGL 255, 0 lx (DN; percentiles 1/10/50/90/99 over pixels, "
          f"range over positions): {np.round(low.min(0), 1).tolist()} .. "
          f"{np.round(low.max(0), 1).tolist()}")  # fmt: skip
    print("  all three shifts saturate above (lx): "
          f"{np.round(onset.min(0)).tolist()} .. {np.round(onset.max(0)).tolist()}")  # fmt: skip
    noise = np.array([p["noise_order_error_fraction"] for p in per])
    print(f"noise study, 600 lx + sigma {NOISE_SIGMA:g}, centerline pipeline, MIGL "
          f"{'/'.join(f'{m:.0f}' for m in NOISE_MIGLS)}: wrong orders max "
          f"{100 * noise.max():.3f} % over {len(depths)} positions")  # fmt: skip
    secs = {m: sum(p["seconds"][m] for p in per) for m in ch4.UNWRAP_MODES}
    print(f"block seconds summed over positions: known {secs['known']:.0f} s, centerline "
          f"{secs['centerline']:.0f} s")  # fmt: skip
    if args.json:
        args.json.write_text(
            json.dumps({"rows": rows, "positions": per, "wall_s": wall, "block_s": secs}, indent=1)
            + "\n"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
