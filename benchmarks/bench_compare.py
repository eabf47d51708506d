"""Benchmark: every saturation strategy side by side on the virtual rig, full size.

Run ``.venv/bin/python benchmarks/bench_compare.py`` (the rig's 648 x 494 camera, the four
scenes, every method of :data:`hdrfringe.tasks.compare.METHODS`; ``--resolution 160x120``
for a quick look, ``--scenes specular_part --strategies lpa-1,adaptive`` to limit it (the
methods still run in the table's order on one rig per scene), ``-o DIR`` to also keep the
table, JSON and plot as ``hdrfringe compare`` writes them). It prints the markdown table of
docs/compare.md, the budget rows (issue 26) beside the best other row with full coverage
(``budget_summary``), and the wall time.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from hdrfringe.tasks.compare import (
    budget_summary,
    compare,
    compare_markdown,
    compare_specs,
    parse_resolution,
    write_compare,
)


def main(argv: list[str] | None = None) -> int:
    """Run the comparison and print its table.

    Parameters
    ----------
    argv : list of str, optional
        Command-line arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit code.
    """
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolution", default="default", help="camera WIDTHxHEIGHT")
    ap.add_argument("--pitch", type=float, default=8.0, help="finest pitch (px)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("-o", "--output", type=Path, default=None, help="also write the folder")
    ap.add_argument("--scenes", default=None, help="comma-separated scenes (default all)")
    ap.add_argument("--strategies", default=None, help="comma-separated strategies (default all)")
    args = ap.parse_args(argv)
    size = parse_resolution(args.resolution)
    t0 = time.perf_counter()
    rows = compare(
        None if args.scenes is None else args.scenes.split(","),
        None if args.strategies is None else args.strategies.split(","),
        resolution=size,
        pitch=args.pitch,
        seed=args.seed,
        progress=lambda label: print(
            f"  {time.perf_counter() - t0:7.1f} s  {label}", file=sys.stderr
        ),
    )
    settings = {
        "resolution": "648x494" if size is None else f"{size[0]}x{size[1]}",
        "pitches_px": [s.pitch_px for s in compare_specs(args.pitch)],
        "steps": 4,
        "seed": args.seed,
    }
    header = "Settings: " + ", ".join(f"{k} {v}" for k, v in settings.items())
    print(compare_markdown(rows, header=header))
    lines = budget_summary(rows)
    if lines:  # issue 26: the budget rows beside the best other full-coverage row
        print("\nBudget rows (best other: lowest std in order at >= 99.9 % coverage):")
        print("\n".join(f"- {line}" for line in lines))
    print(f"total {time.perf_counter() - t0:.1f} s")
    if args.output is not None:
        write_compare(args.output, rows, settings, force=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
