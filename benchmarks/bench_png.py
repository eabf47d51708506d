"""Benchmark: writing capture PNGs at zlib level 1 (``PNG_COMPRESS_LEVEL``) against Pillow's
default level.

Run ``.venv/bin/python benchmarks/bench_png.py`` (``--repeats N``, default 15; ``--size WxH``,
default the virtual rig's 648x494). A few seconds. See benchmarks/README.md.

The images: one 4-step set of the virtual rig's checkerboard (sensor noise, saturated white
squares), as ``simulate`` writes them. Each round writes every image once per case, the cases in
a seeded random order (a busy machine slows both alike); printed: the median time per image
per case, their ratio (default / level 1) and the file-size ratio (level 1 / default). The files
read back equal to the images at both levels (PNG is lossless; checked every round).
"""

from __future__ import annotations

import argparse
import random
import statistics
import tempfile
import time
from pathlib import Path

import imageio.v3 as iio
import numpy as np

from hdrfringe.core.patterns import FringeSpec
from hdrfringe.io.captures import PNG_COMPRESS_LEVEL
from hdrfringe.rig.scenes import checkerboard
from hdrfringe.rig.simulated import CameraModel, SimulatedRig


def main() -> None:
    """Time both levels interleaved and print the ratios."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument("--size", default="648x494")
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    rig = SimulatedRig(checkerboard(), camera=CameraModel(width=width, height=height), seed=0)
    images = rig.capture(FringeSpec("sinusoidal", 4, 8.0).frames())
    cases: dict[str, dict] = {
        "default": {},
        f"level {PNG_COMPRESS_LEVEL}": {"compress_level": PNG_COMPRESS_LEVEL},
    }
    times: dict[str, list[float]] = {name: [] for name in cases}
    sizes: dict[str, int] = {}
    order = random.Random(0)
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(args.repeats):
            names = list(cases)
            order.shuffle(names)
            for name in names:
                paths = [Path(tmp) / f"{name.replace(' ', '')}_{k}.png" for k in range(len(images))]
                start = time.perf_counter()
                for img, path in zip(images, paths, strict=True):
                    iio.imwrite(path, img, **cases[name])
                times[name].append((time.perf_counter() - start) / len(images))
                sizes[name] = sum(p.stat().st_size for p in paths)
                for img, path in zip(images, paths, strict=True):
                    if not np.array_equal(iio.imread(path), img):
                        raise SystemExit(f"{path.name} does not read back equal")
    median = {name: statistics.median(v) for name, v in times.items()}
    fast = f"level {PNG_COMPRESS_LEVEL}"
    print(f"{width}x{height}, {len(images)} images, {args.repeats} rounds (median per image):")
    for name in cases:
        print(f"  {name:>8}: {1e3 * median[name]:7.1f} ms, {sizes[name] / len(images):9.0f} bytes")
    print(f"default / {fast} time: {median['default'] / median[fast]:.2f}x")
    print(f"{fast} / default size: {sizes[fast] / sizes['default']:.3f}")


if __name__ == "__main__":
    main()
