"""Benchmark: phase decoding and temporal unwrapping, hdrfringe versus plain numpy.

Run ``.venv/bin/python benchmarks/bench_phase.py`` (or ``make bench``); ``--json PATH`` also
writes the results as JSON, ``--quick`` uses fewer repeats; ``--blocks`` times only the fused
kernel (hdrfringe.core._blockdecode) per block size on 1 and 2 threads, with the native kernel
(hdrfringe/core/_native/decode.c) and with the numpy path (``HDRFRINGE_NATIVE=0``). See
benchmarks/README.md.

What is timed (median of repeated runs, per call):

(a) 4-step sinusoidal set, 648x494 pixels, 8-bit, seeded synthetic with saturation:
    - ``decode_set``: everything the library computes for a set (phase, modulation, mean,
      data modulation, saturation count, validity, NaN masking), with the native kernel when
      it is built, and with the numpy path (``HDRFRINGE_NATIVE=0``);
    - ``sinusoidal_phase`` + ``saturation_count``: the same numerical core without the
      validity bookkeeping;
    - reference: a straightforward numpy loop over the shifts accumulating S, C (and the sum
      for the mean) in float64, ``np.arctan2``, ``np.sqrt``, ``(imgs == 255).sum(0)``.
(b) 3-frequency temporal unwrapping of 648x494 wrapped maps, pitches 1024 px (one period
    across a 1024 px projector), 128 px and 16 px:
    - ``unwrap_temporal`` (which also builds the fringe-order residual map);
    - reference: the same formula ``Phi_k = phi_k + 2*pi*round((Phi_{k-1}*p_{k-1}/p_k -
      phi_k)/(2*pi))`` written directly.

Before timing, each pair is checked to agree numerically.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
import timeit
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

from hdrfringe.core import _native
from hdrfringe.core.patterns import FringeSpec, fringe_gray
from hdrfringe.core.phase import decode_set, saturation_count, sinusoidal_phase
from hdrfringe.core.unwrap import unwrap_temporal

TWO_PI = 2.0 * np.pi
HEIGHT, WIDTH = 494, 648
STEPS = 4
SEED = 20240601
PITCHES = (1024.0, 128.0, 16.0)


# ---------------------------------------------------------------------------------------------
# Synthetic data (seeded)
# ---------------------------------------------------------------------------------------------


def projector_x(rng: np.random.Generator) -> np.ndarray:
    """Projector x seen by each camera pixel: a tilted plane with a smooth bump, ~10..1010 px."""
    rows, cols = np.mgrid[0:HEIGHT, 0:WIDTH].astype(np.float64)
    bump = 25.0 * np.exp(-((cols - 300) ** 2 + (rows - 250) ** 2) / (2 * 80.0**2))
    return 10.0 + 1.55 * cols + 0.08 * rows + bump + rng.normal(0, 0.01, (HEIGHT, WIDTH))


def fringe_set(rng: np.random.Generator) -> tuple[np.ndarray, FringeSpec]:
    """4-step 8-bit set with camera gain above 1, so bright fringes clip at 255."""
    spec = FringeSpec("sinusoidal", STEPS, 16.0, "vertical", 40, 255)
    x = projector_x(rng)
    # reflectivity varies across the field: some regions clip, most do not
    gain = 0.75 + 0.40 * np.exp(-(((np.arange(WIDTH) - 450) / 120.0) ** 2))[None, :]
    imgs = np.stack([5.0 + gain * fringe_gray(x, spec, k) for k in range(STEPS)])
    imgs += rng.normal(0.0, 1.5, imgs.shape)
    return np.clip(np.rint(imgs), 0, 255).astype(np.uint8), spec


def wrapped_maps(rng: np.random.Generator) -> list[np.ndarray]:
    """Wrapped phases 2*pi*x/p mod 2*pi with 0.02 rad noise, coarsest first."""
    x = projector_x(rng)
    return [
        np.mod(TWO_PI * x / p + rng.normal(0.0, 0.02, x.shape), TWO_PI).astype(np.float64)
        for p in PITCHES
    ]


# ---------------------------------------------------------------------------------------------
# Plain-numpy references
# ---------------------------------------------------------------------------------------------


def reference_phase(imgs: np.ndarray, full: int = 255):
    """Loop over shifts, float64 accumulators: phase in [0, 2*pi), b, mean, saturation count."""
    n = imgs.shape[0]
    s = np.zeros(imgs.shape[1:])
    c = np.zeros(imgs.shape[1:])
    total = np.zeros(imgs.shape[1:])
    for k in range(n):
        f = imgs[k].astype(np.float64)
        s += f * np.sin(TWO_PI * k / n)
        c += f * np.cos(TWO_PI * k / n)
        total += f
    phase = np.mod(np.arctan2(-s, c), TWO_PI)
    modulation = (2.0 / n) * np.sqrt(s * s + c * c)
    return phase, modulation, total / n, (imgs == full).sum(0)


def reference_temporal(maps: list[np.ndarray], pitches: tuple[float, ...]) -> np.ndarray:
    current = np.mod(maps[0], TWO_PI)
    for k in range(1, len(maps)):
        predicted = current * (pitches[k - 1] / pitches[k])
        current = maps[k] + TWO_PI * np.rint((predicted - maps[k]) / TWO_PI)
    return current


# ---------------------------------------------------------------------------------------------
# Timing
# ---------------------------------------------------------------------------------------------


def with_env(name: str, value: str, call: Callable[[], Any]) -> Callable[[], Any]:
    """``call`` with the environment variable ``name`` set to ``value`` for its duration."""

    def run() -> Any:
        old = os.environ.get(name)
        os.environ[name] = value
        try:
            return call()
        finally:
            if old is None:
                del os.environ[name]
            else:
                os.environ[name] = old

    return run


def native_status() -> str:
    """Whether ``decode_set`` runs the native kernel here (built, not disabled)."""
    if _native.load("decode") is not None:
        return "native decode kernel: built and used"
    if not _native.native_enabled():
        return "native decode kernel: disabled (HDRFRINGE_NATIVE=0)"
    return "native decode kernel: NOT BUILT (numpy path; run `make native`)"


def median_time(func: Callable[[], Any], repeat: int) -> float:
    """Median seconds per call over ``repeat`` timings (each of enough calls to take ~0.2 s)."""
    timer = timeit.Timer(func)
    number, _ = timer.autorange()
    number = max(1, number)
    times = timer.repeat(repeat=repeat, number=number)
    return float(np.median(times) / number)


def wrapped_abs_diff(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(np.mod(a - b + np.pi, TWO_PI) - np.pi)


def check_agreement(imgs: np.ndarray, spec: FringeSpec, maps: list[np.ndarray]) -> dict:
    """Ours and the references must agree before timing them; returns the differences."""
    phase, b, mean = sinusoidal_phase(imgs)
    sat = saturation_count(imgs, 8)
    r_phase, r_b, r_mean, r_sat = reference_phase(imgs)
    res = decode_set(imgs, spec, 8)
    res_np = with_env("HDRFRINGE_NATIVE", "0", lambda: decode_set(imgs, spec, 8))()
    fields = ("wrapped_phase", "modulation", "mean_intensity", "data_modulation")
    out = {
        "phase_max_abs_diff_rad": float(wrapped_abs_diff(phase, r_phase).max()),
        "modulation_max_abs_diff_dn": float(np.abs(b - r_b).max()),
        "mean_max_abs_diff_dn": float(np.abs(mean - r_mean).max()),
        "saturation_count_equal": bool(np.array_equal(sat, r_sat)),
        "decode_set_phase_max_abs_diff_rad": float(
            np.nanmax(wrapped_abs_diff(res.wrapped_phase, r_phase))
        ),
        "decode_set_saturation_count_equal": bool(np.array_equal(res.saturation_count, r_sat)),
        "decode_set_native_equals_numpy_path": bool(
            all(np.array_equal(getattr(res, f), getattr(res_np, f), equal_nan=True) for f in fields)
            and np.array_equal(res.valid, res_np.valid)
            and np.array_equal(res.saturation_count, res_np.saturation_count)
        ),
    }
    ours_u = unwrap_temporal(maps, list(PITCHES))
    ref_u = reference_temporal(maps, PITCHES)
    out["unwrap_max_abs_diff_rad"] = float(np.abs(ours_u - ref_u).max())
    ok = (
        out["phase_max_abs_diff_rad"] < 1e-12
        and out["modulation_max_abs_diff_dn"] < 1e-9
        and out["mean_max_abs_diff_dn"] < 1e-9
        and out["saturation_count_equal"]
        and out["decode_set_phase_max_abs_diff_rad"] < 1e-12
        and out["decode_set_saturation_count_equal"]
        and out["decode_set_native_equals_numpy_path"]
        and out["unwrap_max_abs_diff_rad"] < 1e-12
    )
    if not ok:
        raise SystemExit(f"ours and the reference disagree: {out}")
    return out


#: The native kernel's instruction-set variants (hdrfringe/core/_native/decode.c, ``isa``).
ISA_NAMES = ("SSE2", "AVX2", "AVX512F")

BLOCK_SIZES = (2048, 4096, 8192, 16384, 32768, 65536, HEIGHT * WIDTH)


def block_sweep(imgs: np.ndarray, repeat: int) -> list[dict]:
    """Time the fused kernel (every decode_set map) per block size, 1 and 2 threads, with the
    native kernel (when built) and the numpy path; each instruction-set variant of the native
    kernel that this CPU runs (default block, 1 thread); and the start and join of one pool
    thread doing nothing (the fixed cost of a second thread).

    Interleaved: each round times every (path, block, threads) case once; medians over
    ``repeat`` rounds of CPU time (all threads) and wall time per call, plus the plain
    reference.
    """
    from hdrfringe.core._blockdecode import decode_sinusoidal_blocks

    flat = imgs.reshape(imgs.shape[0], -1)
    cases: dict[str, Callable[[], Any]] = {"plain numpy reference": lambda: reference_phase(imgs)}
    paths = (("native", "1"), ("numpy", "0")) if _native.load("decode") else (("numpy", "0"),)
    for path, flag in paths:
        for block in BLOCK_SIZES:
            for threads in (1, 2):

                def call(block: int = block, threads: int = threads, flag: str = flag) -> Any:
                    os.environ["HDRFRINGE_DECODE_THREADS"] = str(threads)
                    os.environ["HDRFRINGE_NATIVE"] = flag
                    return decode_sinusoidal_blocks(flat, full=255, min_modulation=2.0, block=block)

                name = (
                    f"{path:<6} block {block:>6} px, {threads} thread{'s' if threads > 1 else ''}"
                )
                cases[name] = call
    lib = _native.load("decode")
    if lib is not None:  # the kernel's instruction-set variants (same bits), default block
        from hdrfringe.core import _blockdecode

        for isa in range(int(lib.hf_decode_isa()) + 1):

            def call_isa(isa: int = isa) -> Any:
                os.environ["HDRFRINGE_DECODE_THREADS"] = "1"
                os.environ["HDRFRINGE_NATIVE"] = "1"
                _blockdecode._ISA = isa
                try:
                    return decode_sinusoidal_blocks(flat, full=255, min_modulation=2.0)
                finally:
                    _blockdecode._ISA = -1

            cases[f"native {ISA_NAMES[isa]:<7} default block, 1 thread"] = call_isa

    def start_and_join() -> None:  # what the pool of a 2-thread decode costs by itself
        with ThreadPoolExecutor(1) as pool:
            pool.submit(int)

    cases["start + join one pool thread (no work)"] = start_and_join
    cpu: dict[str, list[float]] = {k: [] for k in cases}
    wall: dict[str, list[float]] = {k: [] for k in cases}
    old = {k: os.environ.get(k) for k in ("HDRFRINGE_DECODE_THREADS", "HDRFRINGE_NATIVE")}
    try:
        for _ in range(repeat):
            for name, call in cases.items():
                c0, w0 = time.process_time(), time.perf_counter()
                for _ in range(5):
                    call()
                cpu[name].append((time.process_time() - c0) / 5)
                wall[name].append((time.perf_counter() - w0) / 5)
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
    return [
        {
            "case": name,
            "cpu_ms": 1e3 * float(np.median(cpu[name])),
            "wall_ms": 1e3 * float(np.median(wall[name])),
        }
        for name in cases
    ]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", metavar="PATH", help="also write the results as JSON")
    ap.add_argument("--repeat", type=int, default=15, help="timings per case (median taken)")
    ap.add_argument("--quick", action="store_true", help="5 repeats (smoke run)")
    ap.add_argument(
        "--blocks", action="store_true", help="only the fused kernel's block-size sweep"
    )
    args = ap.parse_args(argv)
    repeat = 5 if args.quick else args.repeat

    rng = np.random.default_rng(SEED)
    imgs, spec = fringe_set(rng)
    if args.blocks:
        print(
            f"fused block decode, every decode_set map: {STEPS}-step {WIDTH}x{HEIGHT} uint8; "
            f"median of {repeat} interleaved rounds; load average {os.getloadavg()[0]:.1f}; "
            f"{native_status()}"
        )
        print(f"\n{'case':<40} {'CPU ms':>7} {'wall ms':>8}")
        for r in block_sweep(imgs, repeat):
            print(f"{r['case']:<40} {r['cpu_ms']:7.2f} {r['wall_ms']:8.2f}")
        return 0
    maps = wrapped_maps(rng)
    sat_frac = float(np.mean((imgs == 255).any(axis=0)))
    agreement = check_agreement(imgs, spec, maps)

    cases = [
        (
            "(a) decode_set vs reference",
            lambda: decode_set(imgs, spec, 8),
            lambda: reference_phase(imgs),
        ),
        (
            "(a) decode_set, numpy path (HDRFRINGE_NATIVE=0) vs reference",
            with_env("HDRFRINGE_NATIVE", "0", lambda: decode_set(imgs, spec, 8)),
            lambda: reference_phase(imgs),
        ),
        (
            "(a) sinusoidal_phase + saturation_count vs reference",
            lambda: (sinusoidal_phase(imgs), saturation_count(imgs, 8)),
            lambda: reference_phase(imgs),
        ),
        (
            "(b) unwrap_temporal (3 freq) vs reference",
            lambda: unwrap_temporal(maps, list(PITCHES)),
            lambda: reference_temporal(maps, PITCHES),
        ),
    ]
    rows = []
    for name, ours, ref in cases:
        t_ours = median_time(ours, repeat)
        t_ref = median_time(ref, repeat)
        rows.append(
            {
                "case": name,
                "ours_ms": 1e3 * t_ours,
                "reference_ms": 1e3 * t_ref,
                "ours_over_reference": t_ours / t_ref,
                "speedup_reference_over_ours": t_ref / t_ours,
            }
        )

    print(
        f"hdrfringe phase benchmark: {STEPS}-step {WIDTH}x{HEIGHT} uint8 "
        f"({100 * sat_frac:.1f} % of pixels clipped in >= 1 shift); "
        f"unwrap pitches {', '.join(f'{p:g}' for p in PITCHES)} px"
    )
    print(
        f"python {platform.python_version()}, numpy {np.__version__}, "
        f"{os.cpu_count()} CPUs, {platform.machine()}; median of {repeat} runs; "
        f"{native_status()}"
    )
    print(f"agreement: {agreement}")
    w = max(len(r["case"]) for r in rows)
    print(f"\n{'case':<{w}}  {'ours ms':>9}  {'ref ms':>9}  {'ours/ref':>8}  {'ref/ours':>8}")
    for r in rows:
        print(
            f"{r['case']:<{w}}  {r['ours_ms']:9.2f}  {r['reference_ms']:9.2f}  "
            f"{r['ours_over_reference']:8.2f}  {r['speedup_reference_over_ours']:8.2f}"
        )
    if args.json:
        payload = {
            "shape": [STEPS, HEIGHT, WIDTH],
            "dtype": "uint8",
            "saturated_fraction": sat_frac,
            "pitches_px": list(PITCHES),
            "repeat": repeat,
            "python": platform.python_version(),
            "numpy": np.__version__,
            "cpu_count": os.cpu_count(),
            "agreement": agreement,
            "native": native_status(),
            "results": rows,
        }
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(payload, fh, indent=1)
            fh.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
