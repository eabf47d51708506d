"""Benchmark: decoding one phase-shifted set, hdrfringe against its peers, interleaved.

Run ``python benchmarks/bench_peers.py`` (or ``make bench-peers``); ``--json PATH`` also writes
the results, ``--rounds N`` sets the number of interleaved rounds. The peers are optional:
install them in a separate environment with ``pip install -e '.[bench]'`` (fringes pulls numba
and opencv-contrib-python, whose ``cv2`` replaces the headless build in that environment); a
peer that is missing gets the row "not installed". See benchmarks/README.md, "Peers".

Data: the seeded 4-step 648x494 uint8 set of benchmarks/bench_phase.py (22.8 % of pixels
clipped in at least one shift), and a 3-step set of the same scene for OpenCV's PSP, which
decodes three shifts only. Cases:

- hdrfringe ``decode_set``: every map (phase, I', I'', psi, saturation count, validity, NaN
  where invalid), with its default threads and with ``HDRFRINGE_DECODE_THREADS=1``; with the
  native kernel (hdrfringe/core/_native/decode.c, when built: the header line says whether it is)
  and with the numpy path (``HDRFRINGE_NATIVE=0``);
- plain numpy: the float64 loop of bench_phase.py (phase, I', I'', saturation count);
- fringes: its numba decode kernel (``fringes.decoder_numba.decode``, what ``Fringes.decode``
  runs before any unwrapping) on one thread and on all threads;
- OpenCV: ``cv2.structured_light.SinusoidalPattern`` with ``methodId = PSP``,
  ``computePhaseMap`` on the 3-step set, when the installed cv2 has the contrib module.

Before timing, every phase is compared with the plain-numpy reference: hdrfringe must agree
within 1e-6 rad (it is bit-identical) or the script stops; a peer's phase is put into the
contract's convention (fringes: ``pi - p``; OpenCV: as returned) and the fraction of pixels
within 1e-3 rad is printed beside its time. Timing: each case's calls per timing are chosen
once (about 0.1 s); then every round times every case once, in turn, so a busy machine slows
all cases alike; medians over rounds, and ratios per round (their median and range). With
numba installed it also times one float64 atan2 per pixel, numpy's ufunc against a numba loop
(the floor of a compiled per-pixel kernel; benchmarks/README.md, "Why numpy blocks"). The CPU
time (process time of all threads, per call) is printed too: on a shared machine it varies
far less than wall time, but it does not show what a second thread gains.
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
from pathlib import Path
from typing import Any

import numpy as np

import bench_phase as bp  # the same directory: on sys.path when run as a script
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.phase import decode_set, sinusoidal_phase

TWO_PI = 2.0 * np.pi


def wrapped_abs_diff(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(np.mod(a - b + np.pi, TWO_PI) - np.pi)


def three_step_set() -> tuple[np.ndarray, FringeSpec]:
    """The bench_phase scene as a 3-step set (same seed, same gain, same noise model)."""
    rng = np.random.default_rng(bp.SEED)
    spec = FringeSpec("sinusoidal", 3, 16.0, "vertical", 40, 255)
    x = bp.projector_x(rng)
    gain = 0.75 + 0.40 * np.exp(-(((np.arange(bp.WIDTH) - 450) / 120.0) ** 2))[None, :]
    imgs = np.stack([5.0 + gain * bp.fringe_gray(x, spec, k) for k in range(3)])
    imgs += rng.normal(0.0, 1.5, imgs.shape)
    return np.clip(np.rint(imgs), 0, 255).astype(np.uint8), spec


def with_threads(threads: int, call: Callable[[], Any]) -> Callable[[], Any]:
    """``call`` with ``HDRFRINGE_DECODE_THREADS`` set to ``threads`` for its duration."""
    return bp.with_env("HDRFRINGE_DECODE_THREADS", str(threads), call)


def numpy_path(call: Callable[[], Any]) -> Callable[[], Any]:
    """``call`` with ``HDRFRINGE_NATIVE=0``: hdrfringe's numpy block kernel, no C kernel."""
    return bp.with_env("HDRFRINGE_NATIVE", "0", call)


def fringes_decode(
    imgs: np.ndarray, pitch: float, threads: int = 1, convert: bool = True
) -> Callable[[], Any] | None:
    """fringes' numba decode kernel of ``imgs`` (N, H, W) on ``threads`` threads (0: all).

    The kernel ``Fringes.decode`` calls (one direction, one set of N shifts, wavelength
    ``pitch``), without the spatial unwrapping that ``Fringes.decode`` adds when one period does
    not cover the pattern. The call returns the phase in the contract's convention (``pi - p``,
    in float64) with ``convert``, else the kernel's own outputs (float32 maps: brightness,
    modulation, phase, ...). None when fringes is not installed.
    """
    try:
        import fringes
        import numba
        from fringes.decoder_numba import decode
    except ImportError:
        return None
    n, height, width = imgs.shape
    f = fringes.Fringes()
    f.X, f.Y = width, height
    f.D, f.K, f.N = 1, 1, n
    f.l = pitch
    video = imgs[:, :, :, None]  # fringes' video shape (T, Y, X, C)
    args = (f._N, f._v, -f._f if f.reverse else f._f, f.L, f.UMR, f.crt, f.gcd, f.x0, f.p0)
    all_threads = numba.config.NUMBA_NUM_THREADS

    def run() -> Any:
        numba.set_num_threads(threads or all_threads)
        try:
            out = decode(video, *args, 0.0, 0.0, False, f.mode, True)
        finally:
            numba.set_num_threads(all_threads)
        if not convert:
            return out
        p = out[2][0, :, :, 0]
        return np.mod(np.pi - p.astype(np.float64), TWO_PI)

    return run


def opencv_psp(imgs3: np.ndarray) -> Callable[[], Any] | None:
    """OpenCV's PSP wrapped phase of a 3-step set, or None without cv2.structured_light."""
    try:
        import cv2
    except ImportError:
        return None
    sl = getattr(cv2, "structured_light", None)
    if sl is None:
        return None
    params = sl.SinusoidalPattern.Params()
    params.methodId = sl.PSP
    params.width, params.height = imgs3.shape[2], imgs3.shape[1]
    pattern = sl.SinusoidalPattern_create(params)
    frames = [np.ascontiguousarray(im) for im in imgs3]

    def run() -> np.ndarray:
        wrapped, _ = pattern.computePhaseMap(frames)
        return np.asarray(wrapped)[: imgs3.shape[1], : imgs3.shape[2]].astype(np.float64)

    return run


def atan2_floor(rounds: int) -> dict[str, float] | None:
    """CPU ms of one float64 atan2 per pixel of the set: numpy's (SIMD) ufunc against a
    numba loop (what a compiled per-pixel kernel calls: the scalar libm function). None
    without numba."""
    try:
        import numba
    except ImportError:
        return None

    @numba.njit(cache=False)
    def loop(s: np.ndarray, c: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover
        for i in range(s.size):
            out[i] = np.arctan2(s[i], c[i])

    rng = np.random.default_rng(bp.SEED)
    s, c = rng.normal(size=(2, bp.HEIGHT * bp.WIDTH))
    out = np.empty_like(s)
    loop(s, c, out)  # compile
    cpu: dict[str, list[float]] = {"numpy arctan2": [], "numba loop": []}
    for _ in range(rounds):
        for name, call in (
            ("numpy arctan2", lambda: np.arctan2(s, c, out=out)),
            ("numba loop", lambda: loop(s, c, out)),
        ):
            c0 = time.process_time()
            for _ in range(5):
                call()
            cpu[name].append((time.process_time() - c0) / 5 * 1e3)
    return {name: float(np.median(v)) for name, v in cpu.items()}


def calls_per_timing(func: Callable[[], Any], target: float = 0.1) -> int:
    """Calls per timing so that one timing takes about ``target`` seconds."""
    t0 = time.perf_counter()
    func()
    one = max(time.perf_counter() - t0, 1e-6)
    return max(1, int(target / one))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=15, help="interleaved rounds (median taken)")
    ap.add_argument("--json", metavar="PATH", help="also write the results as JSON")
    args = ap.parse_args(argv)

    rng = np.random.default_rng(bp.SEED)
    imgs, spec = bp.fringe_set(rng)
    imgs3, _ = three_step_set()
    ref_phase = bp.reference_phase(imgs)[0]
    ref3 = bp.reference_phase(imgs3)[0]

    # name -> (call, phase of the call's result, reference phase, convention note)
    cases: dict[str, tuple[Callable[[], Any] | None, Callable[[Any], np.ndarray], np.ndarray]] = {
        "hdrfringe decode_set (all maps)": (
            lambda: decode_set(imgs, spec, 8),
            lambda r: r.wrapped_phase,
            ref_phase,
        ),
        "hdrfringe decode_set, 1 thread": (
            with_threads(1, lambda: decode_set(imgs, spec, 8)),
            lambda r: r.wrapped_phase,
            ref_phase,
        ),
        "hdrfringe decode_set, numpy path": (
            numpy_path(lambda: decode_set(imgs, spec, 8)),
            lambda r: r.wrapped_phase,
            ref_phase,
        ),
        "hdrfringe decode_set, numpy path, 1 thread": (
            numpy_path(with_threads(1, lambda: decode_set(imgs, spec, 8))),
            lambda r: r.wrapped_phase,
            ref_phase,
        ),
        "plain numpy (phase, I', I'', sat)": (
            lambda: bp.reference_phase(imgs),
            lambda r: r[0],
            ref_phase,
        ),
        "fringes decode, 1 thread": (fringes_decode(imgs, 16.0, 1), lambda r: r, ref_phase),
        "fringes decode, all threads": (fringes_decode(imgs, 16.0, 0), lambda r: r, ref_phase),
        "hdrfringe sinusoidal_phase, 3-step": (
            lambda: sinusoidal_phase(imgs3),
            lambda r: r[0],
            ref3,
        ),
        "OpenCV PSP computePhaseMap, 3-step": (opencv_psp(imgs3), lambda r: r, ref3),
    }

    agreement: dict[str, float | None] = {}
    failed: dict[str, str] = {}
    for name, (call, phase_of, ref) in cases.items():
        if call is None:
            agreement[name] = None
            continue
        try:
            phase = phase_of(call())  # also the warm-up (numba loads its cache here)
        except Exception as exc:  # a peer that fails on this data is reported, not timed
            if name.startswith(("hdrfringe", "plain")):
                raise
            failed[name] = f"fails on this set: {type(exc).__name__}: {str(exc).strip()[:90]}"
            continue
        diff = wrapped_abs_diff(phase, ref)
        finite = np.isfinite(diff)
        if name.startswith(("hdrfringe", "plain")):
            worst = float(np.max(diff[finite])) if finite.any() else 0.0
            if worst > 1e-6:
                raise SystemExit(f"{name}: phase differs from the reference by {worst:.3g} rad")
        agreement[name] = float(np.mean(diff[finite] < 1e-3)) if finite.any() else 0.0

    live = {name: c[0] for name, c in cases.items() if c[0] is not None and name not in failed}
    numbers = {name: calls_per_timing(call) for name, call in live.items()}
    times: dict[str, list[float]] = {name: [] for name in live}
    cpu: dict[str, list[float]] = {name: [] for name in live}
    load_before = os.getloadavg()[0]
    for _ in range(args.rounds):
        for name, call in live.items():
            c0 = time.process_time()
            t = timeit.timeit(call, number=numbers[name]) / numbers[name]
            cpu[name].append((time.process_time() - c0) / numbers[name])
            times[name].append(t)
    load_after = os.getloadavg()[0]

    ours = np.array(times["hdrfringe decode_set (all maps)"])
    ours3 = np.array(times["hdrfringe sinusoidal_phase, 3-step"])
    rows = []
    for name in cases:
        row: dict[str, Any] = {"case": name}
        if name not in live:
            row["status"] = failed.get(name, "not installed")
        else:
            t = np.array(times[name])
            base = ours3 if "3-step" in name else ours
            ratio = t / base  # per round: this case over ours in the same round
            c = np.array(cpu[name])
            row.update(
                status="ok",
                cpu_median_ms=1e3 * float(np.median(c)),
                median_ms=1e3 * float(np.median(t)),
                min_ms=1e3 * float(t.min()),
                ratio_median=float(np.median(ratio)),
                ratio_min=float(ratio.min()),
                ratio_max=float(ratio.max()),
                agree_fraction=agreement[name],
            )
        rows.append(row)

    print(
        f"decode of one set: {bp.STEPS}-step (3-step for OpenCV) {bp.WIDTH}x{bp.HEIGHT} uint8; "
        f"python {platform.python_version()}, numpy {np.__version__}, {os.cpu_count()} CPUs, "
        f"load average {load_before:.1f} -> {load_after:.1f}; {args.rounds} interleaved rounds"
    )
    print(bp.native_status())
    print("ratio = case time / hdrfringe time in the same round (decode_set; 3-step rows: ")
    print("sinusoidal_phase 3-step); agree = fraction of pixels within 1e-3 rad of Eq. 2.2\n")
    w = max(len(r["case"]) for r in rows)
    print(
        f"{'case':<{w}}  {'median ms':>9}  {'ratio':>6}  {'ratio range':>13}  {'CPU ms':>7}  "
        f"{'agree':>6}"
    )
    for r in rows:
        if r["status"] != "ok":
            print(f"{r['case']:<{w}}  {r['status']}")
            continue
        print(
            f"{r['case']:<{w}}  {r['median_ms']:9.2f}  {r['ratio_median']:6.2f}  "
            f"{r['ratio_min']:5.2f} - {r['ratio_max']:5.2f}  {r['cpu_median_ms']:7.2f}  "
            f"{r['agree_fraction']:6.3f}"
        )
    floor = atan2_floor(args.rounds)
    if floor is not None:
        print(
            f"\none float64 atan2 per pixel ({bp.WIDTH}x{bp.HEIGHT}), CPU ms: numpy's ufunc "
            f"{floor['numpy arctan2']:.2f}, a numba loop {floor['numba loop']:.2f}"
        )
    if args.json:
        payload = {
            "atan2_cpu_ms": floor,
            "shape": [bp.STEPS, bp.HEIGHT, bp.WIDTH],
            "rounds": args.rounds,
            "python": platform.python_version(),
            "numpy": np.__version__,
            "cpu_count": os.cpu_count(),
            "load_average": [load_before, load_after],
            "native": bp.native_status(),
            "results": rows,
        }
        Path(args.json).write_text(json.dumps(payload, indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
