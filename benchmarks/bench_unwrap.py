"""Benchmark: spatial unwrapping, ``unwrap_spatial`` against scikit-image's (issue 16).

Run ``.venv/bin/python benchmarks/bench_unwrap.py`` (``--repeats N``, default 15; ``--json
PATH`` also writes the results). About 30 s. See benchmarks/README.md.

Maps (seeded): a wrapped phase 648x494 of projector x = tilted plane plus a smooth bump at
pitch 16 px, 0.02 rad noise; (a) NaN-free; (b) the same with invalid pixels (NaN): a clipped
vertical band cut by a valid bridge, round holes, and scattered specks (about 10 % invalid);
(c) NaN-free with a 50x80 patch of 1.2 rad noise (residues: ``unwrap_spatial`` tries the
integration, finds loops that do not close, and calls scikit-image: the cost of trying).

Cases, timed interleaved (one round = one call of each, so a busy machine slows every case
alike), wall time and CPU time of this process (``time.process_time``: on a shared machine it
varies much less from run to run), medians of ``--repeats`` rounds:

- ``unwrap_spatial`` as it is now;
- ``unwrap_spatial`` as it was before (region medians from one ``lexsort`` of every valid
  pixel, a masked array always; kept verbatim in tests/test_unwrap_identity.py);
- ``skimage.restoration.unwrap_phase`` on the same map shifted to ``[-pi, pi)`` (the NaN-free
  map for (a); for (b) a masked array with the NaN replaced by 0, since scikit-image does not
  return on NaN).

``--steps`` also times the steps of ``unwrap_spatial`` on the NaN-free map one by one (CPU).
``--determinism`` also counts, on 40 noisy 48x80 maps (residues: scikit-image decides; half
with 20 % NaN), the maps and pixels whose fringe orders change with the C ``rand()`` state
(4 states), and checks that the residue-free benchmark maps give the same bytes in every state.

Before timing, the script checks that ours and the version of before give the same NaN pattern
and the same integer fringe order at every pixel (ours is ``wrapped + 2 pi K`` in one step, so
values can differ from before's in the last bit), that ours differs from scikit-image's
unwrapping by a multiple of 2 pi that is constant over each region, and it says which path
``unwrap_spatial`` took (integration of the wrapped differences, or scikit-image); it stops
if a check fails.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from scipy import ndimage
from skimage.restoration import unwrap_phase

from hdrfringe import unwrap as unwrap_module
from hdrfringe.unwrap import unwrap_spatial

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository: its tests
from tests.test_unwrap_identity import _reference_unwrap_spatial, reseed_c_rand

HEIGHT, WIDTH = 494, 648
SEED = 20240601


def make_maps() -> dict[str, np.ndarray]:
    """The wrapped maps: NaN-free, and with invalid regions."""
    rng = np.random.default_rng(SEED)
    rows, cols = np.mgrid[0:HEIGHT, 0:WIDTH].astype(np.float64)
    x = 10.0 + 1.55 * cols + 0.08 * rows
    x += 25.0 * np.exp(-((rows - 250.0) ** 2 + (cols - 420.0) ** 2) / (2 * 60.0**2))
    wrapped = np.mod(2 * np.pi * x / 16.0 + rng.normal(0, 0.02, x.shape), 2 * np.pi)
    holes = (cols > 300) & (cols < 330) & ~((rows > 200) & (rows < 215))
    for r, c, rad in ((100, 100, 20), (380, 500, 30), (420, 150, 12)):
        holes |= (rows - r) ** 2 + (cols - c) ** 2 < rad**2
    holes |= rng.random(x.shape) < 0.04
    with_nan = wrapped.copy()
    with_nan[holes] = np.nan
    residues = wrapped.copy()  # a noisy patch: loops that do not close, scikit-image decides
    patch = (slice(60, 110), slice(60, 140))
    residues[patch] = np.mod(residues[patch] + rng.normal(0, 1.2, (50, 80)), 2 * np.pi)
    return {"NaN-free": wrapped, "with NaN": with_nan, "with residues": residues}


def skimage_call(wrapped: np.ndarray) -> Callable[[], np.ndarray]:
    """scikit-image's unwrapper on the same map (NaN replaced by 0 and masked)."""
    valid = np.isfinite(wrapped)
    centred = np.where(valid, wrapped, 0.0) - np.pi
    if valid.all():
        return lambda: unwrap_phase(centred, rng=0)
    masked = np.ma.array(centred, mask=~valid)
    return lambda: np.ma.getdata(unwrap_phase(masked, rng=0))


def before_call(wrapped: np.ndarray) -> Callable[[], np.ndarray]:
    """``unwrap_spatial`` as it was before (tests/test_unwrap_identity.py keeps it verbatim)."""
    return lambda: _reference_unwrap_spatial(wrapped)


def check(wrapped: np.ndarray) -> str:
    """Ours has the orders of before and is scikit-image's up to 2 pi per region; returns the
    path ``unwrap_spatial`` took."""
    taken: list[bool] = []
    real = unwrap_module._path_orders

    def spy(centred: np.ndarray, valid: np.ndarray | None) -> np.ndarray | None:
        result = real(centred, valid)
        taken.append(result is not None)
        return result

    unwrap_module._path_orders = spy  # type: ignore[assignment]
    try:
        reseed_c_rand()
        ours = unwrap_spatial(wrapped)
    finally:
        unwrap_module._path_orders = real  # type: ignore[assignment]
    reseed_c_rand()
    before = before_call(wrapped)()
    valid = np.isfinite(wrapped)
    if not np.array_equal(np.isfinite(ours), np.isfinite(before)):
        raise SystemExit("unwrap_spatial's valid pixels differ from the version of before")
    k_ours = np.rint((ours[valid] - wrapped[valid]) / (2 * np.pi))
    if not np.array_equal(k_ours, np.rint((before[valid] - wrapped[valid]) / (2 * np.pi))):
        raise SystemExit("unwrap_spatial's fringe orders differ from the version of before")
    turns = (ours - (skimage_call(wrapped)() + np.pi)) / (2 * np.pi)
    if not np.allclose(turns[valid], np.rint(turns[valid]), atol=1e-9):
        raise SystemExit("unwrap_spatial is not scikit-image's unwrapping plus 2 pi k")
    labels, n = ndimage.label(valid, structure=unwrap_module._FOUR_CONNECTED)
    k = np.rint(turns[valid])
    lo = ndimage.minimum(k, labels[valid], np.arange(1, n + 1))
    hi = ndimage.maximum(k, labels[valid], np.arange(1, n + 1))
    if not np.array_equal(lo, hi):
        raise SystemExit("unwrap_spatial's 2 pi offset to scikit-image varies within a region")
    return "integration" if taken == [True] else "scikit-image"


def step_times(wrapped: np.ndarray, repeats: int) -> dict[str, float]:
    """CPU ms (median) of each step ``unwrap_spatial`` takes on a map without invalid pixels,
    the steps copied from it: where the time goes."""
    from hdrfringe.unwrap import TWO_PI, _component_medians, _orders_to_window, _path_orders

    runs: dict[str, list[float]] = {}
    for _ in range(repeats):
        marks = [("start", time.process_time())]
        phase = wrapped.astype(np.float64)
        bool(np.isfinite(phase).all())
        marks.append(("copy and check", time.process_time()))
        centred = np.mod(phase, TWO_PI)
        centred -= np.pi
        marks.append(("np.mod, - pi", time.process_time()))
        path = _path_orders(centred, None)
        assert path is not None
        raw = centred + TWO_PI * path
        marks.append(("integration", time.process_time()))
        u = raw.ravel()
        u += np.pi
        u -= phase.ravel()
        u /= TWO_PI
        np.rint(u, out=u)
        u -= u[0]
        marks.append(("order arithmetic", time.process_time()))
        values = u * TWO_PI
        values += phase.ravel()
        median = _component_medians(None, values, 1)
        marks.append(("median", time.process_time()))
        u += _orders_to_window(median, None)[0]
        u *= TWO_PI
        u += phase.ravel()
        marks.append(("offset, w + 2 pi K", time.process_time()))
        for (_, t0), (name, t1) in itertools.pairwise(marks):
            runs.setdefault(name, []).append(1e3 * (t1 - t0))
    return {k: statistics.median(v) for k, v in runs.items()}


def determinism() -> dict[str, int]:
    """Maps and pixels whose orders depend on the C rand() state (see the module docstring)."""
    from tests.test_unwrap_identity import _surface

    seeds = (0, 1, 12345, 99)
    maps_differ = pixels = 0
    for case in range(40):
        rng = np.random.default_rng(case)
        w = np.mod(_surface(rng, (48, 80)) + rng.normal(0, 0.8, (48, 80)), 2 * np.pi)
        if case % 2:
            w[rng.random(w.shape) < 0.2] = np.nan
        outs = []
        for seed in seeds:
            reseed_c_rand(seed)
            outs.append(unwrap_spatial(w))
        ok = np.isfinite(outs[0])
        moved = [int(np.sum(np.rint((o[ok] - outs[0][ok]) / (2 * np.pi)) != 0)) for o in outs]
        if any(not np.array_equal(o.view(np.int64), outs[0].view(np.int64)) for o in outs):
            maps_differ += 1
            pixels += max(moved)
    same = 0
    for wrapped in make_maps().values():
        outs = []
        for seed in seeds:
            reseed_c_rand(seed)
            outs.append(unwrap_spatial(wrapped))
        same += all(np.array_equal(o.view(np.int64), outs[0].view(np.int64)) for o in outs)
    return {"noisy_maps": 40, "maps_differ": maps_differ, "pixels_other_order": pixels,
            "benchmark_maps_same_bytes": same}  # fmt: skip


def main() -> None:
    """Check, then time every case ``--repeats`` times, interleaved, and print medians."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--json", type=str, default=None)
    ap.add_argument("--steps", action="store_true", help="also time unwrap_spatial's steps")
    ap.add_argument("--determinism", action="store_true", help="also count rand()-dependence")
    args = ap.parse_args()

    maps = make_maps()
    result: dict[str, dict] = {}
    load = os.getloadavg()[0]
    print(f"{platform.machine()}, {os.cpu_count()} CPUs, Python {platform.python_version()}, "
          f"numpy {np.__version__}; load average {load:.2f} at the start")  # fmt: skip
    print(f"{HEIGHT}x{WIDTH}, median of {args.repeats} interleaved rounds (ms)")
    for name, wrapped in maps.items():
        path = check(wrapped)
        cases = {
            "unwrap_spatial": lambda w=wrapped: unwrap_spatial(w),
            "unwrap_spatial before (lexsort medians)": before_call(wrapped),
            "skimage unwrap_phase": skimage_call(wrapped),
        }
        for f in cases.values():  # warm-up
            f()
        times: dict[str, list[float]] = {k: [] for k in cases}
        cpu: dict[str, list[float]] = {k: [] for k in cases}
        for _ in range(args.repeats):
            for k, f in cases.items():
                c0, t0 = time.process_time(), time.perf_counter()
                f()
                times[k].append(1e3 * (time.perf_counter() - t0))
                cpu[k].append(1e3 * (time.process_time() - c0))
        invalid = 100 * float(np.mean(~np.isfinite(wrapped)))
        print(f"({name}: {invalid:.1f} % invalid, unwrap_spatial by {path})")
        print(f"  {'':<42} wall ms  / skimage     cpu ms  / skimage")
        result[name] = {"path": path}
        for label, data in (("wall", times), ("cpu", cpu)):
            med = {k: statistics.median(v) for k, v in data.items()}
            sk = med["skimage unwrap_phase"]
            result[name][label] = {"runs_ms": data, "median_ms": med,
                                   "over_skimage": {k: v / sk for k, v in med.items()}}  # fmt: skip
        for k in cases:
            w, c = result[name]["wall"], result[name]["cpu"]
            print(f"  {k:<42} {w['median_ms'][k]:7.1f} {w['over_skimage'][k]:6.2f}"
                  f"      {c['median_ms'][k]:7.1f} {c['over_skimage'][k]:6.2f}")  # fmt: skip
    if args.steps:
        steps = step_times(maps["NaN-free"], args.repeats)
        print("unwrap_spatial's steps on the NaN-free map, CPU ms:")
        for k, v in steps.items():
            print(f"  {k:<24} {v:7.2f}")
        print(f"  total {sum(steps.values()):.2f} ms")
        result["steps_cpu_ms"] = steps  # type: ignore[assignment]
    if args.determinism:
        det = determinism()
        print(f"rand() dependence: {det['maps_differ']} of {det['noisy_maps']} noisy maps "
              f"(residues) give other orders under 4 rand() states, at "
              f"{det['pixels_other_order']} pixels in all; the benchmark maps giving the same "
              f"bytes in every state: {det['benchmark_maps_same_bytes']} of 3")  # fmt: skip
        result["determinism"] = det  # type: ignore[assignment]
    print(f"load average {os.getloadavg()[0]:.2f} at the end")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f)


if __name__ == "__main__":
    main()
