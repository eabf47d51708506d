"""Benchmark: Ch. 4 measurements per second, the sweep's fast path on 1 and 2 workers.

Run ``.venv/bin/python research/studies/bench_sweep.py`` (``make bench-sweep``); ``--json PATH``
also writes the results. See research/studies/README.md.

One measurement = one phase-shifted set of the white plate at 648x494 captured, decoded,
turned into height with the pattern's calibration and compared with the true depth (a cell of
``hdrfringe reproduce ch4``). Timed in the same run:

(a) baseline, the general path on one core: ``SimulatedRig.capture`` of the set (full virtual
    rig per frame), ``decode_set``, ``Calibration.height``, RMSE;
(b) the sweep's fast path on one core: :func:`hdrfringe_thesis.ch4.ch4_block` (per-residue
    basis images, float32 noise, shared calibration), calibration included;
(c) the same blocks through the sweep engine on a local dask cluster of 1 and of 2 workers.

Reported: measurements per second and the ratios (b)/(a), 2 workers / 1 worker.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from hdrfringe.core.calibration import measurement_mask
from hdrfringe.core.phase import decode_set
from hdrfringe.rig.simulated import Lighting
from hdrfringe_thesis import ch4
from hdrfringe_thesis.engine import SweepGrid, run_sweep

PATTERNS = ("sinusoidal-3", "triangular-3", "triangular-2")
PITCHES = (6, 12)
MIGLS = tuple(float(m) for m in range(255, 104, -15))  # 11
DEPTHS = (10.0, 26.0, 42.0)
LUX = (0.0, 600.0)


def baseline(n: int) -> float:
    """Measurements per second of the general path (a), ``n`` measurements."""
    setup = ch4.Ch4Setup()
    spec = ch4.pattern_spec("sinusoidal-3", 6)
    cal, _ = ch4.calibrate_pattern("sinusoidal-3", 6, setup, DEPTHS)
    plate = ch4.PlateSweep(26.0, setup, spec)
    rig = plate.rig.replace(lighting=Lighting(ambient_lux=600.0))
    mask = measurement_mask((setup.height, setup.width), setup.border_px)
    t0 = time.perf_counter()
    for i in range(n):
        imgs = rig.capture(spec.with_migl(MIGLS[i % len(MIGLS)]).frames())
        ph = decode_set(imgs, spec, 8, reject_saturated=False)
        phase = ch4.orders_from_expected(ph.wrapped_phase, plate.expected_phase)
        err = cal.height(phase)[mask] - 26.0
        float(np.sqrt(np.nanmean(err * err)))
    return n / (time.perf_counter() - t0)


def grid() -> SweepGrid:
    g = ch4.ch4_grid(quick=False)
    return SweepGrid(
        dims={
            "pattern": list(PATTERNS),
            "pitch": list(PITCHES),
            "lux": list(LUX),
            "migl": list(MIGLS),
            "depth_mm": list(DEPTHS),
        },
        variables=g.variables,
        block_dims=g.block_dims,
        attrs={"experiment": "benchmark"},
    )


def fast_single() -> float:
    """Measurements per second of the fast path on one core (b), calibration included."""
    setup = ch4.Ch4Setup()
    n = 0
    t0 = time.perf_counter()
    for pattern in PATTERNS:
        for pitch in PITCHES:
            out = ch4.ch4_block(pattern, pitch, LUX, MIGLS, DEPTHS, setup)
            n += out["rmse_mm"].size
    return n / (time.perf_counter() - t0)


def engine(workers: int) -> float:
    """Measurements per second through the engine on a local cluster (c), cluster start
    included (a few seconds: small against a real sweep, not against this benchmark's)."""
    g = grid()
    n = len(PATTERNS) * len(PITCHES) * len(LUX) * len(MIGLS) * len(DEPTHS)
    folder = Path(tempfile.mkdtemp(prefix="bench-sweep-"))
    try:
        t0 = time.perf_counter()
        run_sweep(
            folder / "b.zarr",
            g,
            ch4.ch4_task,
            {"setup": ch4.Ch4Setup().to_dict()},
            n_workers=workers,
            progress=False,
        )
        return n / (time.perf_counter() - t0)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", type=Path, help="also write the results here")
    args = ap.parse_args(argv)
    res: dict[str, Any] = {
        "machine": {
            "cpus": os.cpu_count(),
            "python": platform.python_version(),
            "numpy": np.__version__,
        },
        "grid": {
            "patterns": PATTERNS,
            "pitches": PITCHES,
            "migls": len(MIGLS),
            "depths": len(DEPTHS),
            "lux": LUX,
            "image": "648x494",
        },
    }
    res["baseline_per_s"] = baseline(40)
    res["fast_1core_per_s"] = fast_single()
    res["engine_1worker_per_s"] = engine(1)
    res["engine_2workers_per_s"] = engine(2)
    res["ratio_fast_vs_baseline"] = res["fast_1core_per_s"] / res["baseline_per_s"]
    res["ratio_2_vs_1_workers"] = res["engine_2workers_per_s"] / res["engine_1worker_per_s"]
    rows = [
        ("(a) general path, 1 core", res["baseline_per_s"]),
        ("(b) fast path, 1 core", res["fast_1core_per_s"]),
        ("(c) engine, 1 worker", res["engine_1worker_per_s"]),
        ("(c) engine, 2 workers", res["engine_2workers_per_s"]),
    ]
    for name, v in rows:
        print(f"{name:28s} {v:8.1f} measurements/s")
    print(f"fast path / general path: {res['ratio_fast_vs_baseline']:.2f}x")
    print(f"2 workers / 1 worker:     {res['ratio_2_vs_1_workers']:.2f}x")
    full = 2 * 39525
    print(
        f"full Ch. 4 grid ({full} measurements) at the 2-worker rate: "
        f"{full / res['engine_2workers_per_s'] / 60:.1f} min (Sec. 4.3 simulations extra)"
    )
    if args.json:
        args.json.write_text(json.dumps(res, indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
