"""DPA's and LPA's set counts over every pitch 5..20 px: thesis Fig. 6.6 on the virtual rig.

The Ch. 6 experiments of ``hdrfringe reproduce`` (:func:`hdrfringe_thesis.adaptive.experiments`,
the checkerboard and the 600 lx white plate, sinusoidal 4-step) at one position (18 mm) and
every integer pitch from 5 to 20 px, with the quick camera (324 x 247,
:data:`hdrfringe_thesis.ch4.QUICK_SETUP`) and the reproduction's DPA correction. Prints the
sets per method and pitch, the least-squares slope over pitch, and the ratios of the thesis's
Tables 6.1-6.2 (means over pitches 6..20). research/docs/reproduction.md ("Tests") quotes this
output; research/tests/test_reproduce_adaptive.py asserts the trends that hold on the quick grid.

Run: ``.venv/bin/python research/studies/bench_dpa_sets.py [--json out.json]`` (about 6 minutes on
one core: the checkerboard cells capture up to 180 sets each).
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Sequence

import numpy as np

from hdrfringe_thesis.adaptive import adaptive_cell, experiments, train_correction
from hdrfringe_thesis.ch4 import QUICK_SETUP

__all__ = ["DEPTH_MM", "PITCHES", "RATIOS", "main", "study", "summary"]

PITCHES = tuple(range(5, 21))
DEPTH_MM = 18.0
#: (store, numerator, denominator, thesis ratio) of Tables 6.1 (plate) and 6.2 (checkerboard).
RATIOS = (
    ("ch6_plate", "dpa-10", "lpa-15", 12.86 / 13.75),
    ("ch6_plate", "dpa-20", "lpa-20", 7.06 / 9.81),
    ("ch6_plate", "dpa-10", "lpa-10", float("nan")),
    ("checkerboard", "dpa-10", "lpa-15", 29.33 / 14.0),
    ("checkerboard", "dpa-20", "lpa-20", 29.33 / 10.0),
)


def study(pitches: Sequence[int] = PITCHES) -> dict[str, dict[int, dict[str, float]]]:
    """Sets captured by every method of the two Ch. 6 experiments, per pitch.

    Parameters
    ----------
    pitches : sequence of int
        The pitches (px).

    Returns
    -------
    dict
        ``{store: {pitch: {method: sets}}}``.
    """
    correction = train_correction(QUICK_SETUP)
    exps = experiments(quick=True)
    out: dict[str, dict[int, dict[str, float]]] = {}
    for store in ("ch6_plate", "checkerboard"):
        exp = exps[store]
        out[store] = {}
        for pitch in pitches:
            t0 = time.perf_counter()
            cell = adaptive_cell(exp, "sinusoidal-4", pitch, DEPTH_MM, QUICK_SETUP, correction)
            out[store][pitch] = dict(zip(exp.methods, cell["sets"].tolist(), strict=True))
            print(f"{store} pitch {pitch}: {time.perf_counter() - t0:.1f} s", flush=True)
    return out


def summary(sets: dict[str, dict[int, dict[str, float]]]) -> str:
    """The counts per pitch with their slope, then the thesis's ratios.

    Parameters
    ----------
    sets : dict
        :func:`study`'s result.

    Returns
    -------
    str
        Plain text.
    """
    lines = []
    for store, by_pitch in sets.items():
        pitches = np.array(sorted(by_pitch), dtype=float)
        for method in next(iter(by_pitch.values())):
            v = np.array([by_pitch[int(p)][method] for p in pitches])
            slope = np.polyfit(pitches, v, 1)[0]
            counts = " ".join(f"{x:g}" for x in v)
            lines.append(f"{store:12s} {method:8s} slope {slope:+.2f}/px  {counts}")
    lines.append("ratios of mean sets over pitches 6..20 (ours / thesis):")
    for store, a, b, thesis in RATIOS:
        by_pitch = sets[store]
        keep = [p for p in by_pitch if p >= 6]
        ratio = np.mean([by_pitch[p][a] for p in keep]) / np.mean([by_pitch[p][b] for p in keep])
        lines.append(f"  {store:12s} {a} / {b}: {ratio:.2f} / {thesis:.2f}")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> None:
    """Command line: run the study, print the summary, optionally write JSON.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments (default ``sys.argv[1:]``).
    """
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", help="write the counts to this file")
    args = parser.parse_args(argv)
    sets = study()
    print(summary(sets))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(sets, f, indent=1)


if __name__ == "__main__":
    main()
