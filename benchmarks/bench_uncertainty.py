"""What the predicted std costs ``measure`` (issue 15 item 2, issue 16's wall-time budget).

A 648 x 494 virtual-rig plate (4-step sets at 1024, 64 and 8 px) and a linear calibration
from the same rig (0, 5, 10 mm) are made in memory; then ``pipeline.measure`` followed by
``write_measurement`` (everything ``hdrfringe measure`` does after reading the folder) runs with
and without ``uncertainty``, interleaved, ``--repeats`` times each. Printed: the median time of
each, the ratio of the medians and the per-repeat ratios, and the noise the estimate found
against the rig's own (read 1 DN, rounding 1/12 DN^2, full well 20000 e at 8 bits), and the whole
``uncertainty`` block of ``metrics.json`` (the example in docs/uncertainty.md).

    .venv/bin/python benchmarks/bench_uncertainty.py               # about 30 s idle
    .venv/bin/python benchmarks/bench_uncertainty.py --repeats 3
    .venv/bin/python benchmarks/bench_uncertainty.py --cli      # the command too, ~1 min more
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from hdrfringe.core.calibration import Calibration
from hdrfringe.core.captures import Captures
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.io.calibration_file import save_calibration
from hdrfringe.io.captures import write_capture_folder
from hdrfringe.pipeline import calibrate, measure
from hdrfringe.rig.scenes import plate, white_plate
from hdrfringe.rig.simulated import CameraModel, SimulatedRig
from hdrfringe.tasks.measure import write_measurement


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument(
        "--cli",
        action="store_true",
        help="also time `hdrfringe measure FOLDER -c CAL` with and without --no-uncertainty "
        "(start-up, reading and writing included), interleaved",
    )
    args = ap.parse_args()
    cam = CameraModel()  # 648 x 494, the thesis's camera
    frames = [f for p in (1024.0, 64.0, 8.0) for f in FringeSpec("sinusoidal", 4, p).frames()]
    cal = calibrate(
        [SimulatedRig(white_plate(d), camera=cam).capture_folder(frames) for d in (0, 5, 10)]
    )
    caps = SimulatedRig(plate(4.0), camera=cam).capture_folder(frames)
    times: dict[bool, list[float]] = {True: [], False: []}
    computing: dict[bool, list[float]] = {True: [], False: []}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(args.repeats):
            for on in (True, False):
                t0 = time.perf_counter()
                res = measure(caps, cal, uncertainty=on)
                t1 = time.perf_counter()
                write_measurement(res, Path(tmp) / f"out_{on}", force=True)
                times[on].append(time.perf_counter() - t0)
                computing[on].append(t1 - t0)
    on, off = (statistics.median(times[k]) for k in (True, False))
    c_on, c_off = (statistics.median(computing[k]) for k in (True, False))
    print(f"measure() alone: with {c_on:.3f} s, without {c_off:.3f} s (medians)")
    print(f"measure + write, 648x494, 3 sets of 4: with {on:.3f} s, without {off:.3f} s (medians)")
    ratios = [round(a / b, 3) for a, b in zip(times[True], times[False], strict=True)]
    print(f"ratio of medians {on / off:.3f}; per repeat {ratios}")
    if args.cli:
        _time_cli(caps, cal, args.repeats)
    res = measure(caps, cal)
    u = res.metrics.uncertainty
    assert u is not None
    level = u["median_intensity_dn"]
    truth = float(np.sqrt(1 + 1 / 12 + 255 / 20000 * level))
    print(
        f"noise: {u['noise']['source']}: sigma_I {u['sigma_i_dn']:.3f} DN at {level:.1f} DN "
        f"(the rig's {truth:.3f}); median phase std {u['phase_std_median_rad']:.4f} rad, "
        f"height std {u['height_std_median_mm']:.4f} mm"
    )
    print("metrics.json uncertainty block:", json.dumps(u, indent=1))


def _time_cli(caps: Captures, cal: Calibration, repeats: int) -> None:
    """The command itself, in a fresh interpreter per run (what a user waits for)."""
    with tempfile.TemporaryDirectory() as tmp:
        folder, cal_file = Path(tmp) / "part", Path(tmp) / "cal.h5"
        write_capture_folder(folder, caps)
        save_calibration(cal_file, cal)
        times: dict[bool, list[float]] = {True: [], False: []}
        for _ in range(repeats):
            for on in (True, False):
                cmd = [sys.executable, "-m", "hdrfringe.cli", "measure", str(folder), "-c",
                       str(cal_file), "-o", str(Path(tmp) / f"out_{on}"), "--force"]  # fmt: skip
                if not on:
                    cmd.append("--no-uncertainty")
                t0 = time.perf_counter()
                subprocess.run(cmd, check=True, capture_output=True)
                times[on].append(time.perf_counter() - t0)
    on, off = (statistics.median(times[k]) for k in (True, False))
    ratios = [round(a / b, 3) for a, b in zip(times[True], times[False], strict=True)]
    print(f"hdrfringe measure (CLI): with {on:.3f} s, without {off:.3f} s (medians), ratio "
          f"{on / off:.3f}; per repeat {ratios}")  # fmt: skip


if __name__ == "__main__":
    main()
