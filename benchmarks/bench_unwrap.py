"""Benchmark: spatial unwrapping, ``unwrap_spatial`` against scikit-image's (issue 16).

Run ``.venv/bin/python benchmarks/bench_unwrap.py`` (``--repeats N``, default 15; ``--json
PATH`` also writes the results). About a minute. See benchmarks/README.md.

Maps (seeded, 648x494): a wrapped phase of projector x = tilted plane plus a smooth bump at
pitch 16 px, 0.02 rad noise; (a) NaN-free; (b) the same with invalid pixels (NaN): a clipped
vertical band cut by a valid bridge, round holes, and scattered specks (about 10 % invalid);
(c) NaN-free with a 50x80 patch of 1.2 rad noise (residues); (d) low-modulation patches over
a quarter of the field: 1.0 rad noise there, and 10 % of their pixels NaN (residues
everywhere in them). On (c) and (d) ``unwrap_spatial`` tries the integration, finds loops
that do not close, and calls the reliability-guided unwrapper in C
(``hdrfringe/core/_native/unwrap.c``), or scikit-image when that is not built.

Cases, timed interleaved (one round = one call of each, so a busy machine slows every case
alike; the cases in a seeded random order each round: a call is slower after some calls
than after others, through the heap's state, e.g. right after the lexsort version of before),
wall time and CPU time of this process (``time.process_time``: on a shared machine it
varies much less from run to run), medians of ``--repeats`` rounds:

- ``unwrap_spatial`` as it is now (native kernels on);
- ``unwrap_spatial`` with ``HDRFRINGE_NATIVE=0`` (the scikit-image fallback; on (a) and (b)
  the same path as above);
- ``unwrap_spatial`` as it was before (region medians from one ``lexsort`` of every valid
  pixel, a masked array always; kept verbatim in tests/test_unwrap_identity.py);
- ``skimage.restoration.unwrap_phase`` on the same map shifted to ``[-pi, pi)`` (for maps
  with NaN a masked array with the NaN replaced by 0, since scikit-image does not return on
  NaN);
- on (c) and (d), the native kernel alone with its own radix sort, and with the edges ordered
  by ``numpy.argsort(kind="stable")`` of its keys instead (the keys from the kernel too): the
  measurement behind the choice of the sort.

``--steps`` also times the steps of ``unwrap_spatial`` on the NaN-free map one by one (CPU).
``--determinism`` also counts, on 40 noisy 48x80 maps (residues; half with 20 % NaN), the maps
and pixels whose fringe orders change with the C ``rand()`` state (4 states), with the native
unwrapper and with the scikit-image fallback, and checks that the benchmark maps give the same
bytes in every state. ``--quality N`` also unwraps N seeded maps like (d) (tilt, bump and
patches drawn per seed; noise 0.8, 1.0 or 1.2 rad; NaN in half of them) by the native kernel
and by scikit-image and prints, against the known truth, the fraction of pixels whose fringe
order is wrong (up to one constant per connected region): mean, median, worst, and on how many
maps each is no worse than the other (``--quality-size HxW``, default 494x648).

Before timing, the script checks that ours and the version of before give the same NaN pattern
and, where the integration answers, the same integer fringe order at every pixel (ours is
``wrapped + 2 pi K`` in one step, so values can differ from before's in the last bit) and
scikit-image's unwrapping up to a multiple of 2 pi constant over each region; where the native
kernel answers, that its orders are congruent, that the argsort order gives the same orders,
and it prints on how many pixels the orders differ from scikit-image's (up to one constant per
region). It says which path ``unwrap_spatial`` took; it stops if a check fails.
"""

from __future__ import annotations

import argparse
import contextlib
import itertools
import json
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
from scipy import ndimage
from skimage.restoration import unwrap_phase

from hdrfringe.core import unwrap as unwrap_module
from hdrfringe.core.unwrap import unwrap_spatial

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository: its tests
from tests.test_unwrap_identity import _reference_unwrap_spatial, reseed_c_rand

HEIGHT, WIDTH = 494, 648
SEED = 20240601


def make_maps() -> dict[str, np.ndarray]:
    """The wrapped maps: NaN-free, with invalid regions, with a noisy patch, low modulation."""
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
    residues = wrapped.copy()  # a noisy patch: loops that do not close
    patch = (slice(60, 110), slice(60, 140))
    residues[patch] = np.mod(residues[patch] + rng.normal(0, 1.2, (50, 80)), 2 * np.pi)
    low = noisy_map(SEED, (HEIGHT, WIDTH), 1.0, True)[1]
    return {"NaN-free": wrapped, "with NaN": with_nan, "with residues": residues,
            "low modulation": low}  # fmt: skip


def noisy_map(
    seed: int, shape: tuple[int, int], sigma: float, nan: bool
) -> tuple[np.ndarray, np.ndarray]:
    """(truth, wrapped): a tilted plane with a bump at pitch 16 px, 0.05 rad noise, and round
    low-modulation patches over a quarter of the field with ``sigma`` rad of noise (with
    ``nan``, 10 % of the patches' pixels NaN, as a modulation threshold leaves them)."""
    rng = np.random.default_rng(seed)
    h, w = shape
    rows, cols = np.mgrid[0:h, 0:w].astype(np.float64)
    x = 10.0 + rng.uniform(1.2, 1.8) * cols + rng.uniform(-0.1, 0.1) * rows
    r0, c0, size = rng.uniform(0.3, 0.7) * h, rng.uniform(0.3, 0.7) * w, 0.12 * w
    x += rng.uniform(10, 30) * np.exp(-((rows - r0) ** 2 + (cols - c0) ** 2) / (2 * size**2))
    truth = 2 * np.pi * x / 16.0
    low = np.zeros(shape, bool)
    while low.mean() < 0.25:
        r, c, rad = rng.uniform(0, h), rng.uniform(0, w), rng.uniform(0.05, 0.15) * w
        low |= (rows - r) ** 2 + (cols - c) ** 2 < rad**2
    noise = rng.normal(0, 1, shape) * np.where(low, sigma, 0.05)
    wrapped = np.mod(truth + noise, 2 * np.pi)
    if nan:
        wrapped[low & (rng.random(shape) < 0.1)] = np.nan
    return truth, wrapped


@contextlib.contextmanager
def native(on: bool) -> Iterator[None]:
    """``HDRFRINGE_NATIVE`` set for the duration (``hdrfringe.core._native.load`` reads it per
    call)."""
    old = os.environ.get("HDRFRINGE_NATIVE")
    os.environ["HDRFRINGE_NATIVE"] = "1" if on else "0"
    try:
        yield
    finally:
        if old is None:
            del os.environ["HDRFRINGE_NATIVE"]
        else:
            os.environ["HDRFRINGE_NATIVE"] = old


def fallback_call(wrapped: np.ndarray) -> Callable[[], np.ndarray]:
    """``unwrap_spatial`` with the native kernels off (scikit-image where loops do not close)."""

    def call() -> np.ndarray:
        with native(False):
            return unwrap_spatial(wrapped)

    return call


def kernel_calls(wrapped: np.ndarray) -> dict[str, Callable[[], object]]:
    """The native kernel alone on the map, with its radix sort and with numpy's argsort."""
    valid = np.isfinite(wrapped)
    centred = np.where(valid, np.mod(np.where(valid, wrapped, 0.0), 2 * np.pi) - np.pi, 0.0)
    v = None if valid.all() else valid

    def by_argsort() -> object:
        keys = unwrap_module._native_edge_keys(centred, v)
        return unwrap_module._native_orders(centred, v, np.argsort(keys, kind="stable"))

    return {"native kernel, C radix sort": lambda: unwrap_module._native_orders(centred, v),
            "native kernel, numpy argsort": by_argsort}  # fmt: skip


def region_wrong(result: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Per valid pixel of ``result``: whether its order relative to ``reference`` differs from
    the most common one of its 4-connected region."""
    ok = np.isfinite(result)
    labels, _ = ndimage.label(ok, structure=unwrap_module._FOUR_CONNECTED)
    lab = labels[ok]
    d = np.rint((result[ok] - reference[ok]) / (2 * np.pi)).astype(np.int64)
    d -= d.min()
    counts = np.zeros((lab.max() + 1, d.max() + 1), np.int64)
    np.add.at(counts, (lab, d), 1)
    return d != counts.argmax(axis=1)[lab]


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


def check(wrapped: np.ndarray) -> tuple[str, str]:
    """Ours against the version of before and scikit-image (see the module docstring); returns
    the path ``unwrap_spatial`` took and a note."""
    taken: list[str] = []
    real_path, real_native = unwrap_module._path_orders, unwrap_module._native_orders

    def spy_path(centred: np.ndarray, valid: np.ndarray | None) -> np.ndarray | None:
        result = real_path(centred, valid)
        taken.append("integration" if result is not None else "refused")
        return result

    def spy_native(
        centred: np.ndarray, valid: np.ndarray | None, order: np.ndarray | None = None
    ) -> np.ndarray | None:
        result = real_native(centred, valid, order)
        taken.append("native" if result is not None else "no native")
        return result

    unwrap_module._path_orders = spy_path  # type: ignore[assignment]
    unwrap_module._native_orders = spy_native  # type: ignore[assignment]
    try:
        with native(True):
            ours = unwrap_spatial(wrapped)
    finally:
        unwrap_module._path_orders = real_path  # type: ignore[assignment]
        unwrap_module._native_orders = real_native  # type: ignore[assignment]
    path = {"integration": "integration", "native": "native kernel"}.get(taken[-1], "scikit-image")
    reseed_c_rand()
    before = before_call(wrapped)()
    valid = np.isfinite(wrapped)
    if not np.array_equal(np.isfinite(ours), np.isfinite(before)):
        raise SystemExit("unwrap_spatial's valid pixels differ from the version of before")
    k_ours = np.rint((ours[valid] - wrapped[valid]) / (2 * np.pi))
    if not np.array_equal(ours[valid], wrapped[valid] + 2 * np.pi * k_ours):
        raise SystemExit("unwrap_spatial's values are not wrapped + 2 pi K")
    reseed_c_rand()
    theirs = skimage_call(wrapped)() + np.pi
    if path == "native kernel":
        a, b = kernel_calls(wrapped).values()
        if not np.array_equal(a(), b()):  # type: ignore[arg-type]
            raise SystemExit("the radix sort and numpy's argsort give other orders")
        differ = int(region_wrong(ours, theirs).sum())
        return path, f"{differ} pixels ({100 * differ / valid.sum():.2f} %) with other orders " \
            "than scikit-image's"  # fmt: skip
    if not np.array_equal(k_ours, np.rint((before[valid] - wrapped[valid]) / (2 * np.pi))):
        raise SystemExit("unwrap_spatial's fringe orders differ from the version of before")
    if region_wrong(ours, theirs).any():
        raise SystemExit("unwrap_spatial is not scikit-image's unwrapping plus 2 pi k per region")
    return path, "scikit-image's orders up to 2 pi k per region"


def step_times(wrapped: np.ndarray, repeats: int) -> dict[str, float]:
    """CPU ms (median) of each step ``unwrap_spatial`` takes on a map without invalid pixels,
    the steps copied from it: where the time goes."""
    from hdrfringe.core.unwrap import TWO_PI, _component_medians, _orders_to_window, _path_orders

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
    out: dict[str, int] = {"noisy_maps": 40}
    for label, on in (("native", True), ("fallback", False)):
        maps_differ = pixels = 0
        for case in range(40):
            rng = np.random.default_rng(case)
            w = np.mod(_surface(rng, (48, 80)) + rng.normal(0, 0.8, (48, 80)), 2 * np.pi)
            if case % 2:
                w[rng.random(w.shape) < 0.2] = np.nan
            outs = []
            for seed in seeds:
                reseed_c_rand(seed)
                with native(on):
                    outs.append(unwrap_spatial(w))
            ok = np.isfinite(outs[0])
            moved = [int(np.sum(np.rint((o[ok] - outs[0][ok]) / (2 * np.pi)) != 0)) for o in outs]
            if any(not np.array_equal(o.view(np.int64), outs[0].view(np.int64)) for o in outs):
                maps_differ += 1
                pixels += max(moved)
        out[f"{label}_maps_differ"] = maps_differ
        out[f"{label}_pixels_other_order"] = pixels
    same = 0
    maps = make_maps()
    for wrapped in maps.values():
        outs = []
        for seed in seeds:
            reseed_c_rand(seed)
            with native(True):
                outs.append(unwrap_spatial(wrapped))
        same += all(np.array_equal(o.view(np.int64), outs[0].view(np.int64)) for o in outs)
    out["benchmark_maps"] = len(maps)
    out["benchmark_maps_same_bytes"] = same
    return out


def quality(n_maps: int, shape: tuple[int, int]) -> dict[str, object]:
    """Wrong-order fractions against the truth, native kernel and scikit-image, on ``n_maps``
    seeded low-modulation maps (see the module docstring)."""
    wrong: dict[str, list[float]] = {"native": [], "skimage": []}
    for i in range(n_maps):
        truth, wrapped = noisy_map(1000 + i, shape, (0.8, 1.0, 1.2)[i % 3], i % 2 == 1)
        with native(True):
            ours = unwrap_spatial(wrapped)
        reseed_c_rand()
        theirs = np.where(np.isfinite(wrapped), skimage_call(wrapped)() + np.pi, np.nan)
        for k, u in (("native", ours), ("skimage", theirs)):
            wrong[k].append(float(region_wrong(u, truth).mean()))
    a, b = np.array(wrong["native"]), np.array(wrong["skimage"])
    return {"maps": n_maps, "shape": list(shape), "wrong": wrong,
            "mean": {"native": float(a.mean()), "skimage": float(b.mean())},
            "median": {"native": float(np.median(a)), "skimage": float(np.median(b))},
            "worst": {"native": float(a.max()), "skimage": float(b.max())},
            "native_no_worse": int((a <= b).sum()),
            "skimage_no_worse": int((b <= a).sum())}  # fmt: skip


def main() -> None:
    """Check, then time every case ``--repeats`` times, interleaved, and print medians."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--json", type=str, default=None)
    ap.add_argument("--steps", action="store_true", help="also time unwrap_spatial's steps")
    ap.add_argument("--determinism", action="store_true", help="also count rand()-dependence")
    ap.add_argument("--quality", type=int, default=0, metavar="N",
                    help="also compare wrong-order fractions on N noisy maps")  # fmt: skip
    ap.add_argument("--quality-size", type=str, default=f"{HEIGHT}x{WIDTH}", metavar="HxW")
    args = ap.parse_args()
    if unwrap_module._native_library() is None:
        raise SystemExit("the native unwrapper is not built (make native) or HDRFRINGE_NATIVE=0")

    maps = make_maps()
    result: dict[str, dict] = {}
    load = os.getloadavg()[0]
    print(f"{platform.machine()}, {os.cpu_count()} CPUs, Python {platform.python_version()}, "
          f"numpy {np.__version__}; load average {load:.2f} at the start")  # fmt: skip
    print(f"{HEIGHT}x{WIDTH}, median of {args.repeats} interleaved rounds (ms)")
    for name, wrapped in maps.items():
        path, note = check(wrapped)
        cases: dict[str, Callable[[], object]] = {
            "unwrap_spatial": lambda w=wrapped: unwrap_spatial(w),
            "unwrap_spatial, HDRFRINGE_NATIVE=0": fallback_call(wrapped),
            "unwrap_spatial before (lexsort medians)": before_call(wrapped),
            "skimage unwrap_phase": skimage_call(wrapped),
        }
        if path == "native kernel":
            cases.update(kernel_calls(wrapped))
        for f in cases.values():  # warm-up
            f()
        times: dict[str, list[float]] = {k: [] for k in cases}
        cpu: dict[str, list[float]] = {k: [] for k in cases}
        names = list(cases)
        shuffle = np.random.default_rng(0)
        for _ in range(args.repeats):
            for k in shuffle.permutation(names):  # a case's cost depends on the one before
                f = cases[k]
                c0, t0 = time.process_time(), time.perf_counter()
                f()
                times[k].append(1e3 * (time.perf_counter() - t0))
                cpu[k].append(1e3 * (time.process_time() - c0))
        invalid = 100 * float(np.mean(~np.isfinite(wrapped)))
        print(f"({name}: {invalid:.1f} % invalid, unwrap_spatial by {path}: {note})")
        print(f"  {'':<42} wall ms  / skimage     cpu ms  / skimage")
        result[name] = {"path": path, "note": note}
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
        for label in ("native", "fallback"):
            print(f"rand() dependence ({label}): {det[f'{label}_maps_differ']} of "
                  f"{det['noisy_maps']} noisy maps (residues) give other orders under 4 rand() "
                  f"states, at {det[f'{label}_pixels_other_order']} pixels in all")  # fmt: skip
        print(f"benchmark maps giving the same bytes in every state (native): "
              f"{det['benchmark_maps_same_bytes']} of {det['benchmark_maps']}")  # fmt: skip
        result["determinism"] = det  # type: ignore[assignment]
    if args.quality:
        h, w = (int(v) for v in args.quality_size.lower().split("x"))
        q = quality(args.quality, (h, w))
        print(
            f"wrong fringe orders against the truth, {q['maps']} maps {h}x{w} "
            "(fraction of valid pixels; mean / median / worst):"
        )
        for k in ("native", "skimage"):
            print(f"  {k:<8} {q['mean'][k]:.4f} / {q['median'][k]:.4f} / {q['worst'][k]:.4f}, "  # type: ignore[index]
                  f"no worse than the other on {q[f'{k}_no_worse']} maps")  # fmt: skip
        result["quality"] = q  # type: ignore[assignment]
    print(f"load average {os.getloadavg()[0]:.2f} at the end")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f)


if __name__ == "__main__":
    main()
