"""Benchmark: ``hdrfringe phase`` at real camera sizes against a plain numpy script (issue 30).

Run ``.venv/bin/python benchmarks/bench_large.py`` (or ``make bench-large``); ``--cache DIR``
keeps the rendered capture folders there (rendered once, reused by later runs), ``--sizes
648x494,4096x3000`` a subset, ``--repeats N`` (default 1), ``--json PATH`` also writes the
results, ``--phase-args "..."`` extra options for ``phase``, ``--bytecode`` the package's
modules compiled first (what an installed package has; as in ``bench_cold_start.py``: a
checkout run with ``PYTHONDONTWRITEBYTECODE`` compiles every module at every start). See
benchmarks/README.md, "Real camera sizes".

The folders (rendered once, by a plain numpy evaluation of the contract's fringe equation,
written with the project's ``write_capture_folder``: version 1, 8-bit PNG): three vertical
4-step sinusoidal sets, pitches 1024, 64 and 8 projector px, gray 40..255, seen by a camera of
648x494, 4096x3000 (12 Mpx) and 5120x5120 (26 Mpx) px. Projector column x = a tilted plane
plus a smooth bump spanning about 10..1010 px across the image (so pitch 1024 is one period),
camera gain rising to 1.15 in a vertical band (some pixels clip at 255), seeded noise 1.5 DN.

Per size, in one run, interleaved (one round = each case once, so a busy machine slows both
alike), each a fresh process:

- ``python -m hdrfringe.cli phase FOLDER -o OUT --force`` (the defaults);
- the reference (:data:`REFERENCE`, run as ``python -c``): reads the same PNGs (imageio),
  decodes every set in float32 (phase ``arctan2(-S, C) mod 2 pi``, modulation ``2/N |S, C|``,
  mean, saturation count) and writes the four maps of every set as uncompressed float32 TIFF
  (tifffile).

Each child is waited for with ``os.wait4``, which gives its own resource usage: wall time
(``time.perf_counter`` around it) and peak resident set (``ru_maxrss``). Printed: per size and
case the medians, the ratios phase / reference, and the growth 26 Mpx / 12 Mpx of each case.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from bench_cold_start import compiled_package

SEED = 20240601
PITCHES = (1024.0, 64.0, 8.0)
STEPS = 4
SIZES = ((648, 494), (4096, 3000), (5120, 5120))

#: The plain numpy reference: argv[1] capture folder, argv[2] output folder.
REFERENCE = r"""
import json, sys
from pathlib import Path
import numpy as np, imageio.v3 as iio, tifffile
src, out = Path(sys.argv[1]), Path(sys.argv[2])
out.mkdir(parents=True, exist_ok=True)
frames = json.loads((src / "manifest.json").read_text())["frames"]
sets = {}
for f in frames:
    key = (f["pitch"], f["orientation"])
    sets.setdefault(key, []).append(f)
for (pitch, orient), fs in sets.items():
    n = len(fs)
    s = c = total = sat = None
    for f in fs:
        img = iio.imread(src / f["file"])
        d = np.float32(2 * np.pi * f["shift"] / n)
        x = img.astype(np.float32)
        if s is None:
            s = np.zeros_like(x); c = np.zeros_like(x); total = np.zeros_like(x)
            sat = np.zeros(x.shape, np.uint8)
        s += x * np.float32(np.sin(d)); c += x * np.float32(np.cos(d)); total += x
        sat += img == 255
    phase = np.mod(np.arctan2(-s, c), np.float32(2 * np.pi))
    mod = np.float32(2 / n) * np.hypot(s, c)
    mean = total / np.float32(n)
    tag = f"p{pitch:g}_{orient[0]}"
    for name, arr in (("phase", phase), ("modulation", mod), ("mean", mean),
                      ("saturation_count", sat.astype(np.float32))):
        tifffile.imwrite(out / f"{name}_{tag}.tiff", arr)
"""


def render_folder(path: Path, width: int, height: int) -> Path:
    """The 3-pitch capture folder at ``width`` x ``height``, written by the project's writer."""
    from hdrfringe.core.captures import Captures, ProjectorInfo
    from hdrfringe.core.patterns import FringeSpec

    rng = np.random.default_rng(SEED)
    frames = []
    specs = [FringeSpec("sinusoidal", STEPS, p, imin=40.0, migl=255.0) for p in PITCHES]
    n_images = len(specs) * STEPS
    stack = np.empty((n_images, height, width), dtype=np.uint8)
    u = np.linspace(0.0, 1.0, width)
    gain = 0.8 + 0.35 * np.exp(-(((u - 0.6) / 0.1) ** 2))
    i = 0
    for spec in specs:
        for k in range(STEPS):
            frames.append(spec.frames()[k])
            for r0 in range(0, height, 512):  # row blocks: no full-size float temporaries
                v = np.linspace(0.0, 1.0, height)[r0 : r0 + 512, None]
                x = (
                    10.0
                    + 900.0 * u[None, :]
                    + 60.0 * v
                    + 40.0 * np.exp(-((u[None, :] - 0.4) ** 2 + (v - 0.5) ** 2) / 0.05)
                )
                a, b = (spec.migl + spec.imin) / 2, (spec.migl - spec.imin) / 2
                gray = a + b * np.cos(2 * np.pi * x / spec.pitch_px + 2 * np.pi * k / STEPS)
                img = 5.0 + gain[None, :] * gray + rng.normal(0.0, 1.5, gray.shape)
                stack[i, r0 : r0 + 512] = np.clip(np.rint(img), 0, 255)
            i += 1
    from hdrfringe.io.captures import write_capture_folder

    caps = Captures(frames, stack, 8, projector=ProjectorInfo(width=1024, height=768))
    return write_capture_folder(path, caps, force=True)


def run_child(cmd: list[str]) -> tuple[float, float]:
    """Wall time (s) and peak resident set (MB) of one fresh process running ``cmd``."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    err = proc.stderr.read().decode() if proc.stderr else ""
    if proc.returncode != 0:
        raise SystemExit(f"{cmd[1:5]} failed ({proc.returncode}):\n{err}")
    return wall, usage.ru_maxrss / 1024.0  # Linux: KiB


def folder_for(cache: Path, width: int, height: int) -> Path:
    """The cached capture folder of one size, rendered when missing."""
    path = cache / f"caps_{width}x{height}"
    if not (path / "manifest.json").is_file():
        t0 = time.perf_counter()
        render_folder(path, width, height)
        print(f"rendered {path} in {time.perf_counter() - t0:.1f} s", flush=True)
    return path


def run_sizes(
    sizes: list[tuple[int, ...]], args: Any, cache: Path, tmp: Path, results: dict[str, Any]
) -> None:
    """Every size's cases, interleaved, into ``results`` (printed as they finish)."""
    py = sys.executable
    for w, h in sizes:
        folder = folder_for(cache, w, h)
        out_p, out_r = tmp / "out_phase", tmp / "out_ref"
        cases = {
            "phase": [py, "-m", "hdrfringe.cli", "phase", str(folder), "-o", str(out_p),
                      "--force", *args.phase_args.split()],
            "reference": [py, "-c", REFERENCE, str(folder), str(out_r)],
        }  # fmt: skip
        runs: dict[str, list[tuple[float, float]]] = {k: [] for k in cases}
        for _ in range(args.repeats):
            for name, cmd in cases.items():
                shutil.rmtree(out_r, ignore_errors=True)
                runs[name].append(run_child(cmd))
        key = f"{w}x{h}"
        results[key] = {
            name: {
                "wall_s": statistics.median(r[0] for r in rs),
                "peak_mb": statistics.median(r[1] for r in rs),
                "runs": rs,
            }
            for name, rs in runs.items()
        }
        results[key]["stack_mb"] = len(PITCHES) * STEPS * w * h / 1e6
        p, r = results[key]["phase"], results[key]["reference"]
        print(f"{key:>10}: phase {p['wall_s']:7.2f} s {p['peak_mb']:7.0f} MB | reference "
              f"{r['wall_s']:6.2f} s {r['peak_mb']:6.0f} MB | phase/ref wall "
              f"{p['wall_s'] / r['wall_s']:5.2f}, peak {p['peak_mb'] / r['peak_mb']:5.2f} | "
              f"phase peak {p['peak_mb'] / results[key]['stack_mb']:.1f}x the stack "
              f"({results[key]['stack_mb']:.0f} MB)", flush=True)  # fmt: skip


def main() -> None:
    """Run every size's cases, interleaved, and print medians and ratios."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", type=Path, default=None, help="keep the capture folders here")
    ap.add_argument("--sizes", default=",".join(f"{w}x{h}" for w, h in SIZES))
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--phase-args", default="", help="extra options for phase")
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--bytecode", action="store_true", help="compile the package first")
    args = ap.parse_args()
    sizes = [tuple(int(v) for v in s.split("x")) for s in args.sizes.split(",")]

    tmp = Path(tempfile.mkdtemp(prefix="bench_large_"))
    cache = args.cache if args.cache is not None else tmp
    cache.mkdir(parents=True, exist_ok=True)
    results: dict[str, dict[str, Any]] = {}
    try:
        with compiled_package(args.bytecode):
            run_sizes(sizes, args, cache, tmp, results)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"{platform.machine()}, {os.cpu_count()} CPUs, Python {platform.python_version()}, "
          f"load average {os.getloadavg()[0]:.2f} at the end; {args.repeats} run(s) per case, "
          "median")  # fmt: skip
    small, large = "4096x3000", "5120x5120"
    if small in results and large in results:
        for name in ("phase", "reference"):
            a, b = results[small][name], results[large][name]
            grow = 5120 * 5120 / 4096 / 3000
            print(f"  {name}: 26 Mpx / 12 Mpx: wall {b['wall_s'] / a['wall_s']:.2f}, "
                  f"peak {b['peak_mb'] / a['peak_mb']:.2f} (pixels {grow:.2f})")  # fmt: skip
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
