"""Benchmark: peak memory of decoding one large phase-shifted stack (issue 16).

Run ``.venv/bin/python benchmarks/bench_memory.py`` (or ``make bench-memory``); ``--json PATH``
also writes the results, ``--size 1024x768`` a smaller stack, ``--case NAME`` one case.
See benchmarks/README.md, "Memory of a large decode".

Each case runs in a fresh subprocess, so that one case's freed memory cannot hide another's
peak. The child builds the seeded stack (default 8-step, 4096x3000, uint8: 98 MB) row by row
in uint8, then measures the decode call alone in two ways:

- tracemalloc: numpy reports its array buffers to tracemalloc, so the traced peak during the
  call is the memory the decode allocated (outputs included);
- RSS: the peak resident set (``VmHWM`` of /proc/self/status, reset by writing 5 to
  /proc/self/clear_refs just before the call) minus the resident set before the call: what the
  operating system had to provide, whatever allocated it (Linux only, else left out).

Both are printed as MB and as a multiple of the input stack. The cases: hdrfringe's
``decode_set`` (every map: phase, I', I'', psi in float64, saturation count, validity), the
same with ``dtype=np.float32`` (computed in float64 per block, stored in float32),
``sinusoidal_phase`` with and without the quality maps, the sweeps' float32 phase
(``wrapped_phase(dtype=float32)``), the plain-numpy reference of bench_phase.py, and the
``fringes`` package's decode when installed (a separate environment: ``pip install -e
'.[bench]'``).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tracemalloc
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

SEED = 20240601
STEPS = 8
PITCH = 16.0

CASES = (
    "decode_set",
    "decode_set_float32",
    "sinusoidal_phase",
    "sinusoidal_phase_no_quality",
    "wrapped_phase_float32",
    "numpy_reference",
    "fringes",
)


def make_stack(steps: int, height: int, width: int) -> np.ndarray:
    """Seeded 8-bit fringes (tilted plane, ~8 % clipped), built row block by row block in uint8
    so that building it needs no full-size float temporaries."""
    rng = np.random.default_rng(SEED)
    out = np.empty((steps, height, width), dtype=np.uint8)
    cols = np.arange(width, dtype=np.float64)
    for r0 in range(0, height, 256):
        rows = np.arange(r0, min(r0 + 256, height), dtype=np.float64)[:, None]
        x = 10.0 + 0.25 * cols[None, :] + 0.02 * rows
        gain = 0.8 + 0.35 * np.exp(-(((cols - 0.6 * width) / (0.1 * width)) ** 2))[None, :]
        for k in range(steps):
            wave = 40 + 215 * (0.5 + 0.5 * np.cos(2 * np.pi * x / PITCH + 2 * np.pi * k / steps))
            img = 5.0 + gain * wave + rng.normal(0.0, 1.5, x.shape)
            out[k, r0 : r0 + rows.shape[0]] = np.clip(np.rint(img), 0, 255)
    return out


def numpy_reference(imgs: np.ndarray) -> tuple[np.ndarray, ...]:
    """The plain float64 loop of benchmarks/bench_phase.py (phase, I', I'', saturation count)."""
    n = imgs.shape[0]
    two_pi = 2.0 * np.pi
    s = np.zeros(imgs.shape[1:])
    c = np.zeros(imgs.shape[1:])
    total = np.zeros(imgs.shape[1:])
    for k in range(n):
        f = imgs[k].astype(np.float64)
        s += f * np.sin(two_pi * k / n)
        c += f * np.cos(two_pi * k / n)
        total += f
    phase = np.mod(np.arctan2(-s, c), two_pi)
    modulation = (2.0 / n) * np.sqrt(s * s + c * c)
    return phase, modulation, total / n, (imgs == 255).sum(0)


def fringes_decoder(imgs: np.ndarray) -> Callable[[], Any] | None:
    """The fringes package's decode of the stack on one thread, or None when not installed."""
    try:
        import fringes  # noqa: F401
    except ImportError:
        return None
    from bench_peers import fringes_decode  # same directory

    return fringes_decode(imgs, PITCH, convert=False)  # the kernel's own float32 maps


def case_call(name: str, imgs: np.ndarray) -> Callable[[], Any] | None:
    from hdrfringe.core.patterns import FringeSpec
    from hdrfringe.core.phase import decode_set, sinusoidal_phase, wrapped_phase

    n = imgs.shape[0]
    spec = FringeSpec("sinusoidal", n, PITCH, "vertical", 40, 255)
    calls: dict[str, Callable[[], Any]] = {
        "decode_set": lambda: decode_set(imgs, spec, 8),
        "decode_set_float32": lambda: decode_set(imgs, spec, 8, dtype=np.float32),
        "sinusoidal_phase": lambda: sinusoidal_phase(imgs),
        "sinusoidal_phase_no_quality": lambda: sinusoidal_phase(imgs, quality=False),
        "wrapped_phase_float32": lambda: wrapped_phase(imgs, spec, dtype=np.float32),
        "numpy_reference": lambda: numpy_reference(imgs),
    }
    if name == "fringes":
        return fringes_decoder(imgs)
    return calls[name]


def _status_kb(field: str) -> int | None:
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith(field + ":"):
                return int(line.split()[1])
    except OSError:
        return None
    return None


def _reset_peak_rss() -> bool:
    try:
        Path("/proc/self/clear_refs").write_text("5")
    except OSError:
        return False
    return True


def child(name: str, steps: int, height: int, width: int) -> dict[str, Any]:
    """Run one case in this process and return its measurements."""
    imgs = make_stack(steps, height, width)
    call = case_call(name, imgs)
    if call is None:
        return {"case": name, "status": "not installed"}
    small = imgs[:, :64, :64].copy()
    warm = case_call(name, small)  # warm-up: lazy imports, JIT compilation of peers
    assert warm is not None
    warm()
    rss_before = _status_kb("VmRSS")
    rss_ok = _reset_peak_rss() and rss_before is not None
    tracemalloc.start()
    result = call()
    _, traced_peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    rss_peak = _status_kb("VmHWM")
    out: dict[str, Any] = {
        "case": name,
        "status": "ok",
        "input_mb": imgs.nbytes / 1e6,
        "traced_peak_mb": traced_peak / 1e6,
        "traced_peak_x": traced_peak / imgs.nbytes,
        "outputs_mb": _nbytes(result) / 1e6,
    }
    if rss_ok and rss_peak is not None and rss_before is not None:
        out["rss_peak_mb"] = (rss_peak - rss_before) * 1024 / 1e6
        out["rss_peak_x"] = (rss_peak - rss_before) * 1024 / imgs.nbytes
    return out


def _nbytes(result: Any) -> int:
    """Bytes of the arrays a call returned (a PhaseResult, a tuple of arrays, an array)."""
    if isinstance(result, np.ndarray):
        return result.nbytes
    if isinstance(result, tuple | list):
        return sum(_nbytes(r) for r in result)
    if hasattr(result, "__dataclass_fields__"):
        return sum(_nbytes(getattr(result, f)) for f in result.__dataclass_fields__)
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="4096x3000", help="WIDTHxHEIGHT (default 4096x3000)")
    ap.add_argument("--steps", type=int, default=STEPS)
    ap.add_argument("--case", choices=CASES, action="append", help="only these cases")
    ap.add_argument("--json", metavar="PATH", help="also write the results as JSON")
    ap.add_argument("--child", choices=CASES, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    width, height = (int(v) for v in args.size.lower().split("x"))
    if args.child:
        print(json.dumps(child(args.child, args.steps, height, width)))
        return 0
    here = Path(__file__).resolve().parent
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(
        [str(here), *([env["PYTHONPATH"]] if env.get("PYTHONPATH") else [])]
    )
    rows = []
    for name in args.case or CASES:
        cmd = [sys.executable, str(Path(__file__).resolve()), "--child", name]
        cmd += ["--size", args.size, "--steps", str(args.steps)]
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env, check=False)
        if proc.returncode != 0:
            rows.append({"case": name, "status": f"failed: {proc.stderr.strip()[-300:]}"})
        else:
            rows.append(json.loads(proc.stdout.strip().splitlines()[-1]))
    input_mb = args.steps * width * height / 1e6
    print(
        f"peak memory of one decode: {args.steps}-step {width}x{height} uint8 "
        f"({input_mb:.0f} MB stack); python {platform.python_version()}, numpy {np.__version__}, "
        f"load average {os.getloadavg()[0]:.1f}"
    )
    print(
        f"\n{'case':<28} {'traced MB':>10} {'x input':>8} {'RSS MB':>8} {'x input':>8} "
        f"{'outputs MB':>11}"
    )
    for r in rows:
        if r["status"] != "ok":
            print(f"{r['case']:<28} {r['status']}")
            continue
        rss = (
            f"{r['rss_peak_mb']:8.0f} {r['rss_peak_x']:8.2f}"
            if "rss_peak_mb" in r
            else f"{'-':>8} {'-':>8}"
        )
        print(
            f"{r['case']:<28} {r['traced_peak_mb']:10.0f} {r['traced_peak_x']:8.2f} {rss} "
            f"{r['outputs_mb']:11.0f}"
        )
    if args.json:
        payload = {
            "shape": [args.steps, height, width],
            "python": platform.python_version(),
            "numpy": np.__version__,
            "results": rows,
        }
        Path(args.json).write_text(json.dumps(payload, indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
