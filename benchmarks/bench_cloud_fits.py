"""Benchmark: the plane fit and the grid normals of a measured cloud, against their former
formulations.

Run ``.venv/bin/python benchmarks/bench_cloud_fits.py`` (``--repeats N``, default 5;
``--size WxH``, default 1936x1464, the kimthyung sphere's camera). Under a minute.

The cloud: a tilted plane with a hemisphere in front of it on a camera-sized grid, 1 % of the
points invalid (NaN) and 0.05 mm of noise, seeded. Timed, interleaved in a seeded random order
(a busy machine slows both alike), the median per case:

- ``fit_plane(robust=True)``: :func:`hdrfringe.core.stereo.fit_plane` (the normal from the
  3 x 3 scatter matrix) against the same robust loop with the normal from the SVD of the
  (N, 3) centred points (the former formulation, kept here as the baseline). The two planes
  must agree to 1e-9 (checked).
- ``grid_normals``: :func:`hdrfringe.io.point_cloud.grid_normals` against the former
  derivative (central, forward and backward differences as padded full-size copies, chosen
  per pixel). The normals must be bit-identical (checked).
"""

from __future__ import annotations

import argparse
import random
import statistics
import time
from collections.abc import Callable

import numpy as np

from hdrfringe.core.stereo import fit_plane
from hdrfringe.io.point_cloud import grid_normals


def _cloud(width: int, height: int) -> np.ndarray:
    rng = np.random.default_rng(0)
    v, u = np.mgrid[0:height, 0:width].astype(np.float64)
    x, y = (u - width / 2) * 0.2, (v - height / 2) * 0.2
    z = 600.0 + 0.3 * x - 0.1 * y
    r2 = x**2 + y**2
    radius = 0.25 * min(width, height) * 0.2
    bump = np.sqrt(np.clip(radius**2 - r2, 0.0, None))
    z = z - bump + rng.normal(0.0, 0.05, z.shape)
    xyz = np.stack([x, y, z], axis=-1)
    xyz[rng.random(z.shape) < 0.01] = np.nan
    return xyz


def _svd_robust_plane(xyz: np.ndarray, max_rounds: int = 10) -> tuple[np.ndarray, float]:
    """The former robust plane: the normal from the SVD of the centred points."""
    valid = np.isfinite(xyz).all(axis=-1)
    pts = xyz[valid]
    use = np.ones(pts.shape[0], dtype=bool)
    for _ in range(max_rounds):
        centroid = pts[use].mean(axis=0)
        _, _, vt = np.linalg.svd(pts[use] - centroid, full_matrices=False)
        normal = vt[2]
        offset = float(normal @ centroid)
        if offset > 0:
            normal, offset = -normal, -offset
        dist = pts @ normal - offset
        centre = float(np.median(dist[use]))
        mad = float(np.median(np.abs(dist[use] - centre)))
        keep = np.abs(dist - centre) <= max(3.0 * 1.4826 * mad, 1e-6)
        if keep.sum() < 3 or np.array_equal(keep, use):
            break
        use = keep
    return normal, offset


def _padded_derivative(p: np.ndarray, axis: int) -> np.ndarray:
    """The former grid derivative: padded forward/backward/central copies, chosen per pixel."""
    d = np.full_like(p, np.nan)
    n = p.shape[axis]
    lo = [slice(None)] * 3
    hi = [slice(None)] * 3
    lo[axis], hi[axis] = slice(0, n - 1), slice(1, n)
    step = p[tuple(hi)] - p[tuple(lo)]
    pad = [(0, 0)] * 3
    pad[axis] = (0, 1)
    forward = np.pad(step, pad, constant_values=np.nan)
    pad[axis] = (1, 0)
    backward = np.pad(step, pad, constant_values=np.nan)
    central = 0.5 * (forward + backward)
    for cand in (central, forward, backward):
        use = np.isnan(d[..., :1]) & np.isfinite(cand).all(axis=-1, keepdims=True)
        d = np.where(use, cand, d)
    return d


def _padded_normals(xyz: np.ndarray) -> np.ndarray:
    n = np.cross(_padded_derivative(xyz, 0), _padded_derivative(xyz, 1))
    with np.errstate(invalid="ignore", divide="ignore"):
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
    n[~np.isfinite(xyz).all(axis=-1)] = np.nan
    return n


def _time(cases: dict[str, Callable[[], object]], repeats: int) -> dict[str, float]:
    times: dict[str, list[float]] = {name: [] for name in cases}
    order = random.Random(0)
    for _ in range(repeats):
        names = list(cases)
        order.shuffle(names)
        for name in names:
            start = time.perf_counter()
            cases[name]()
            times[name].append(time.perf_counter() - start)
    return {name: statistics.median(v) for name, v in times.items()}


def main() -> None:
    """Check both pairs agree, time them interleaved and print the ratios."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--size", default="1936x1464")
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    xyz = _cloud(width, height)
    new = fit_plane(xyz, robust=True)
    old_normal, old_offset = _svd_robust_plane(xyz)
    if not (np.allclose(new.normal, old_normal, atol=1e-9) and abs(new.offset - old_offset) < 1e-6):
        raise SystemExit("the scatter-matrix plane differs from the SVD plane")
    x, y, z = (xyz[..., k] for k in range(3))
    if not np.array_equal(grid_normals(x, y, z), _padded_normals(xyz), equal_nan=True):
        raise SystemExit("the grid normals differ from the padded-difference normals")
    plane = _time(
        {"svd": lambda: _svd_robust_plane(xyz), "scatter": lambda: fit_plane(xyz, robust=True)},
        args.repeats,
    )
    normals = _time(
        {"padded": lambda: _padded_normals(xyz), "views": lambda: grid_normals(x, y, z)},
        args.repeats,
    )
    print(f"{width}x{height} cloud, {args.repeats} rounds (median):")
    print(f"  robust plane: SVD {plane['svd']:.3f} s, scatter matrix {plane['scatter']:.3f} s, "
          f"{plane['svd'] / plane['scatter']:.2f}x")  # fmt: skip
    print(f"  grid normals: padded {normals['padded']:.3f} s, views {normals['views']:.3f} s, "
          f"{normals['padded'] / normals['views']:.2f}x")  # fmt: skip


if __name__ == "__main__":
    main()
