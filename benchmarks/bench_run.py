"""Benchmark: a second ``hdrfringe run`` with nothing changed, against the command line's start-up.

Run ``.venv/bin/python benchmarks/bench_run.py`` (``--project FILE``, default the kimthyung
sphere example ``docs/examples/project_kimthyung_sphere.toml``, which needs
``../shared/realdata``; ``--repeats N``, default 7; ``--json PATH`` also writes the results).
See benchmarks/README.md, "A second project run".

The project is run once into a temporary folder (every stage runs: the first run's time is
printed), then, interleaved in rounds (a busy machine slows every case alike), each a fresh
process:

- ``python -m hdrfringe.cli --help``: the start-up every command pays;
- ``python -m hdrfringe.cli run PROJECT -o OUT``: the second run, which hashes the stages'
  inputs, checks their outputs against the manifests and skips every stage.

Printed: the medians (wall and CPU) and the ratio second run / ``--help``: what the skipping
costs beyond starting the program. Issue 27 asks for a second run under 2 s.
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = ROOT / "docs" / "examples" / "project_kimthyung_sphere.toml"


def timed(args: list[str]) -> tuple[float, float, str]:
    """Wall and CPU seconds (children's rusage) of one fresh process, and its standard output."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    res = subprocess.run(
        [sys.executable, "-m", "hdrfringe.cli", *args], capture_output=True, text=True
    )
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if res.returncode != 0:
        sys.exit(f"hdrfringe {' '.join(args)} failed: {res.stderr.strip()}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, res.stdout


def main() -> None:
    """Time the cases and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--project", type=Path, default=DEFAULT)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--json", type=Path)
    opts = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out = str(Path(tmp) / "out")
        first = timed(["run", str(opts.project), "-o", out])
        cases: dict[str, list[tuple[float, float]]] = {"--help": [], "second run": []}
        for _ in range(opts.repeats):
            cases["--help"].append(timed(["--help"])[:2])
            wall, cpu, stdout = timed(["run", str(opts.project), "-o", out])
            if not stdout.splitlines()[-1].startswith("0 of "):
                sys.exit(f"the second run ran a stage:\n{stdout}")
            cases["second run"].append((wall, cpu))
    med = {k: (statistics.median(w for w, _ in v), statistics.median(c for _, c in v))
           for k, v in cases.items()}  # fmt: skip
    print(f"project {opts.project.name}: first run {first[0]:.2f} s wall, {first[1]:.2f} s CPU")
    print(f"{'case':<14}{'wall s':>9}{'CPU s':>9}   (median of {opts.repeats})")
    for name, (wall, cpu) in med.items():
        print(f"{name:<14}{wall:>9.3f}{cpu:>9.3f}")
    ratio = med["second run"][0] / med["--help"][0]
    print(f"second run / --help (wall): {ratio:.2f}; first / second run: "
          f"{first[0] / med['second run'][0]:.0f}")  # fmt: skip
    if opts.json:
        opts.json.write_text(json.dumps({"first_run_s": first[0], "median": med,
                                         "second_over_help": ratio}, indent=1))  # fmt: skip


if __name__ == "__main__":
    main()
