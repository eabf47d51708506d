"""Benchmark: ``hdrfringe measure`` wall time against the library doing the same work (issue 16).

Run ``.venv/bin/python benchmarks/bench_measure.py`` (``--repeats N``, default 7; ``--json
PATH`` also writes the results). See benchmarks/README.md.

The folder: ``hdrfringe simulate checkerboard --pitch 1024,64,8`` (three vertical 4-step sets,
648x494 8-bit, centerline; seed 0). In one run, interleaved (one round = one run of every
case, so a busy machine slows every case alike):

- ``python -c "import numpy"``: the floor every numpy program pays;
- ``python -m hdrfringe.cli measure FOLDER -o OUT --force``, a fresh process (cold);
- the same with ``--no-previews`` (when the command has it);
- in this process after a warm-up, the library-only time of the same work: read the folder,
  ``pipeline.measure`` (decode, unwrap), ``write_measurement`` (the same outputs, staged), and
  the same without previews.

``--bytecode``: the package's modules compiled first, as in ``bench_cold_start.py``.

Printed: medians of wall and CPU time (user + system; children's rusage for the processes,
``time.process_time`` in-process), the library's split (read / compute / write) and the ratios
``measure`` cold / library-only (target at most 2) and (cold - import numpy) / library-only.
"""

from __future__ import annotations

import argparse
import inspect
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_cold_start import _run, compiled_package
from hdrfringe import pipeline
from hdrfringe.io.captures import read_capture_folder
from hdrfringe.io.results import check_output_dir
from hdrfringe.tasks.measure import write_measurement

HAS_NO_PREVIEWS = "previews" in inspect.signature(write_measurement).parameters


def make_folder(path: Path) -> Path:
    """The 3-pitch checkerboard capture folder, written by ``hdrfringe simulate``."""
    cmd = [sys.executable, "-m", "hdrfringe.cli", "simulate", "checkerboard", "-o", str(path)]
    subprocess.run([*cmd, "--pitch", "1024,64,8"], check=True, stdout=subprocess.DEVNULL)
    return path


def library_measure(folder: Path, out: Path, previews: bool = True) -> tuple[float, ...]:
    """What ``hdrfringe measure FOLDER -o OUT --force`` does, in-process; the wall time of its
    three parts (read, compute, write)."""
    out = check_output_dir(out, True)
    t0 = time.perf_counter()
    captures = read_capture_folder(folder)
    t1 = time.perf_counter()
    result = pipeline.measure(captures, None, label=str(folder), strategy=None, params=None,
                              param_sources={}, calibration_source=None)  # fmt: skip
    t2 = time.perf_counter()
    kw = {"previews": previews} if HAS_NO_PREVIEWS else {}
    write_measurement(result, out, force=True, **kw)
    return t1 - t0, t2 - t1, time.perf_counter() - t2


def main() -> None:
    """Time every case ``--repeats`` times, interleaved, and print medians and ratios."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--bytecode", action="store_true", help="compile the package first")
    args = ap.parse_args()

    py = sys.executable
    with tempfile.TemporaryDirectory() as d, compiled_package(args.bytecode):
        folder = make_folder(Path(d) / "caps")
        out = Path(d) / "out"
        measure = [py, "-m", "hdrfringe.cli", "measure", str(folder), "-o", str(out), "--force"]
        cases = {"import numpy": [py, "-c", "import numpy"], "cli measure (cold)": measure}
        lib_cases = {"library-only": True}
        if HAS_NO_PREVIEWS:
            cases["cli measure --no-previews"] = [*measure, "--no-previews"]
            lib_cases["library-only, no previews"] = False
        names = [*cases, *lib_cases]
        times: dict[str, list[float]] = {k: [] for k in names}
        cpu: dict[str, list[float]] = {k: [] for k in names}
        parts: dict[str, list[tuple[float, ...]]] = {k: [] for k in lib_cases}
        library_measure(folder, out)  # warm-up: imports, first-call costs
        for _ in range(args.repeats):
            for name, cmd in cases.items():
                wall, used = _run(cmd)
                times[name].append(wall)
                cpu[name].append(used)
            for name, previews in lib_cases.items():
                c0, t0 = time.process_time(), time.perf_counter()
                parts[name].append(library_measure(folder, out, previews))
                times[name].append(time.perf_counter() - t0)
                cpu[name].append(time.process_time() - c0)

    print(f"{platform.machine()}, {os.cpu_count()} CPUs, Python {platform.python_version()}, "
          f"load average {os.getloadavg()[0]:.2f} at the end; "
          f"package {'compiled' if args.bytecode else 'as found'}")  # fmt: skip
    print(f"median of {args.repeats} interleaved runs (s)")
    print(f"  {'':<28} {'wall':>7} {'(min':>6} {'max)':>6}  {'cpu':>7}")
    result: dict[str, dict] = {}
    pairs = [("cli measure (cold)", "library-only")]
    if HAS_NO_PREVIEWS:
        pairs.append(("cli measure --no-previews", "library-only, no previews"))
    for label, data in (("wall", times), ("cpu", cpu)):
        med = {k: statistics.median(v) for k, v in data.items()}
        ratios = {}
        for cold, lib in pairs:
            ratios[f"{cold} / {lib}"] = med[cold] / med[lib]
            ratios[f"({cold} - import numpy) / {lib}"] = (med[cold] - med["import numpy"]) / med[
                lib
            ]
        result[label] = {"runs_s": data, "median_s": med, "ratios": ratios}
    for k in names:
        w, c = times[k], result["cpu"]["median_s"][k]
        print(f"  {k:<28} {statistics.median(w):7.3f} {min(w):6.3f} {max(w):6.3f}  {c:7.3f}")
    for k, runs in parts.items():
        split = [statistics.median(r[i] for r in runs) for i in range(3)]
        print(f"  {k}: read {split[0]:.3f}, compute {split[1]:.3f}, write {split[2]:.3f} (wall)")
        result.setdefault("library_split_s", {})[k] = split
    print(f"  {'ratios (target: cold / library-only <= 2)':<62} {'wall':>6}  {'cpu':>6}")
    for k in result["wall"]["ratios"]:
        print(f"  {k:<62} {result['wall']['ratios'][k]:6.2f}  {result['cpu']['ratios'][k]:6.2f}")
    if args.json:
        args.json.write_text(json.dumps(result))


if __name__ == "__main__":
    main()
