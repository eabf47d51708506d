"""Benchmark: cold start of the command line against ``python -c "import numpy"`` (issue 16).

Run ``.venv/bin/python benchmarks/bench_cold_start.py`` (``--repeats N``, default 11;
``--json PATH`` also writes the results). See benchmarks/README.md.

In one run, interleaved (one round = one run of every case, so a busy machine slows every
case alike), each a fresh process:

- ``python -c "import numpy"``: the floor every numpy program pays;
- ``python -c "import hdrfringe"``: the lazy public API;
- ``python -m hdrfringe.cli --help``;
- ``python -m hdrfringe.cli phase FOLDER -o OUT --force`` on one 4-step 648x494 8-bit set;

and, in this process after a warm-up, the library-only time of the same ``phase`` work
(read the folder, decode, write the maps into a staged folder): the part of ``phase`` that
is not start-up. Medians are printed with the ratios the issue asks for:
``phase`` cold / (``import numpy`` + library-only), target at most 1.5.

``--imports``: also time, in the same rounds, ``python -c "import numpy, X"`` for what the
``phase`` run imports beyond numpy (:data:`IMPORTS`: the front end, then the readers and
writers the work loads on first use) and print each one's CPU beyond ``import numpy``: what
is left of the start-up, by package.

``--bytecode``: before timing, compile the package's modules into their ``__pycache__``
folders (git-ignored; the folders this creates are removed at the end), as an installed
package has them. Without it, in an environment with ``PYTHONDONTWRITEBYTECODE=1`` and a source
tree without ``__pycache__`` (this one), every fresh process compiles the package's modules.

Wall time is what a user waits for; CPU time (user + system of the process, children's
rusage for the subprocesses, ``time.process_time`` in-process) is printed beside it because on
a shared machine it varies much less than the wall time from run to run.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import json
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from hdrfringe.core.captures import Captures, ProjectorInfo
from hdrfringe.core.decode import decode_captures
from hdrfringe.core.patterns import FringeSpec, fringe_gray
from hdrfringe.core.uncertainty import predict_uncertainty
from hdrfringe.io.captures import read_capture_folder, write_capture_folder
from hdrfringe.io.phase_maps import write_phase_maps
from hdrfringe.io.results import check_output_dir, staged_output_dir

HEIGHT, WIDTH = 494, 648

#: ``--imports``: label -> modules imported after numpy in a fresh process. The front end
#: (typer, rich, the command table), then what ``phase`` loads on first use: PNG reading
#: (imageio over Pillow), TIFF writing, OpenCV (spatial unwrapping's labels), Pillow (header
#: probe, previews); pydantic's modules that typer >= 0.29 imports to coerce options
#: (``typer/_adapters.py``; ``import pydantic`` alone loads them lazily).
IMPORTS: dict[str, str] = {
    "typer + rich": "typer.main, rich.console",
    "cli._app (front end)": "hdrfringe.cli._app",
    "imageio.v3": "imageio.v3",
    "tifffile": "tifffile",
    "cv2": "cv2",
    "PIL (png, draw)": "PIL.Image, PIL.PngImagePlugin, PIL.ImageDraw",
    "pydantic (typer 0.29's use)": "pydantic.type_adapter, pydantic.functional_validators, "
    "pydantic.fields",
}
SEED = 20240601


def make_folder(path: Path) -> Path:
    """A 4-step sinusoidal capture folder, 648x494 8-bit, about 10 % clipped pixels."""
    rng = np.random.default_rng(SEED)
    spec = FringeSpec("sinusoidal", 4, 16.0, "vertical", 40, 255)
    rows, cols = np.mgrid[0:HEIGHT, 0:WIDTH].astype(np.float64)
    x = 10.0 + 1.55 * cols + 0.08 * rows
    gain = np.where((cols > 300) & (cols < 370), 1.15, 0.8)
    imgs = np.stack([15.0 + gain * fringe_gray(x, spec, k) for k in range(spec.steps)])
    imgs = np.clip(np.rint(imgs + rng.normal(0, 1.5, imgs.shape)), 0, 255).astype(np.uint8)
    write_capture_folder(
        path, Captures(spec.frames(), imgs, 8, projector=ProjectorInfo(1024, 768, 8, 2.812))
    )
    return path


def library_phase(folder: Path, out: Path) -> None:
    """What ``hdrfringe phase FOLDER -o OUT --force`` computes and writes, in-process."""
    out = check_output_dir(out, True)
    captures = read_capture_folder(folder)
    decoded = decode_captures(captures)
    unc = predict_uncertainty(captures, decoded)  # the command's default (--uncertainty)
    with staged_output_dir(out, force=True) as tmp:
        write_phase_maps(tmp, decoded, str(folder), uncertainty=unc)


@contextlib.contextmanager
def compiled_package(enabled: bool) -> Iterator[None]:
    """With ``enabled``: the package's modules compiled into ``__pycache__`` (what an installed
    package has) for the duration; the ``__pycache__`` folders created here are removed after."""
    if not enabled:
        yield
        return
    import hdrfringe

    root = Path(hdrfringe.__file__).parent
    before = set(root.rglob("__pycache__"))
    subprocess.run([sys.executable, "-m", "compileall", "-q", str(root)], check=True)
    try:
        yield
    finally:
        for folder in set(root.rglob("__pycache__")) - before:
            shutil.rmtree(folder, ignore_errors=True)


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _run(cmd: list[str]) -> tuple[float, float]:
    """Wall and CPU time of one run of ``cmd``."""
    c0, t0 = _children_cpu(), time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0, _children_cpu() - c0


def main() -> None:
    """Time every case ``--repeats`` times, interleaved, and print medians and ratios."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=11)
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--bytecode", action="store_true", help="compile the package first")
    ap.add_argument("--imports", action="store_true", help="also time the imports, by package")
    args = ap.parse_args()

    py = sys.executable
    with tempfile.TemporaryDirectory() as d, compiled_package(args.bytecode):
        folder = make_folder(Path(d) / "caps")
        out = Path(d) / "out"
        phase = ["phase", str(folder), "-o", str(out), "--force"]
        cases = {
            "import numpy": [py, "-c", "import numpy"],
            "import hdrfringe": [py, "-c", "import hdrfringe"],
            "cli --help": [py, "-m", "hdrfringe.cli", "--help"],
            "cli phase (cold)": [py, "-m", "hdrfringe.cli", *phase],
        }
        if args.imports:
            cases |= {
                f"+ {k}": [py, "-c", f"import numpy, {v}"]
                for k, v in IMPORTS.items()
                if importlib.util.find_spec(v.split(",")[0].split(".")[0]) is not None
            }
        names = [*cases, "phase library-only"]
        times: dict[str, list[float]] = {k: [] for k in names}
        cpu: dict[str, list[float]] = {k: [] for k in names}
        library_phase(folder, out)  # warm-up: imports, first-call costs
        for _ in range(args.repeats):
            for name, cmd in cases.items():
                wall, used = _run(cmd)
                times[name].append(wall)
                cpu[name].append(used)
            c0, t0 = time.process_time(), time.perf_counter()
            library_phase(folder, out)
            times["phase library-only"].append(time.perf_counter() - t0)
            cpu["phase library-only"].append(time.process_time() - c0)

    print(f"{platform.machine()}, {os.cpu_count()} CPUs, Python {platform.python_version()}")
    print(f"median of {args.repeats} interleaved runs (s); load average {os.getloadavg()[0]:.2f}; "
          f"package {'compiled' if args.bytecode else 'as found'}")  # fmt: skip
    print(f"  {'':<30} {'wall':>7} {'(min':>6} {'max)':>6}  {'cpu':>7}")
    result: dict[str, dict] = {}
    for label, data in (("wall", times), ("cpu", cpu)):
        med = {k: statistics.median(v) for k, v in data.items()}
        floor = med["import numpy"] + med["phase library-only"]
        result[label] = {
            "runs_s": data,
            "median_s": med,
            "ratios": {
                "phase cold / (import numpy + library-only)": med["cli phase (cold)"] / floor,
                "phase cold - library-only - import numpy (s)": med["cli phase (cold)"] - floor,
                "--help / import numpy": med["cli --help"] / med["import numpy"],
                "import hdrfringe / import numpy": med["import hdrfringe"] / med["import numpy"],
            },
        }
    for k in names:
        w, c = times[k], result["cpu"]["median_s"][k]
        print(f"  {k:<30} {statistics.median(w):7.3f} {min(w):6.3f} {max(w):6.3f}  {c:7.3f}")
    print(f"  {'ratios':<46} {'wall':>7}  {'cpu':>7}")
    for k in result["wall"]["ratios"]:
        print(f"  {k:<46} {result['wall']['ratios'][k]:7.3f}  {result['cpu']['ratios'][k]:7.3f}")
    added = [k for k in names if k.startswith("+ ")]
    if added:
        print("  CPU beyond import numpy (median - median), s")
        cpu_med = result["cpu"]["median_s"]
        for k in added:
            print(f"  {k:<30} {cpu_med[k] - cpu_med['import numpy']:7.3f}")
    if args.json:
        args.json.write_text(json.dumps(result))


if __name__ == "__main__":
    main()
