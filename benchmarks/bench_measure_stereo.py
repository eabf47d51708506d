"""Benchmark: ``measure -c STEREO.h5`` on the kimthyung sphere against ``phase`` and a plain
numpy triangulation (issue 30).

Run ``.venv/bin/python benchmarks/bench_measure_stereo.py`` (``--repeats N``, default 3;
``--json PATH`` also writes the results). See benchmarks/README.md. Needs the real captures
(``../shared/realdata/kimthyung_sphere``); without them it says so and exits 0.

The folder: the kimthyung sphere imported as the tests import it
(``docs/examples/import/kimthyung_sphere.toml``; 1936x1464, 15 frames: vertical and horizontal
3-step sets of pitch 114, their Gray codes, black frames) and its stereo calibration converted
(``calibrate-stereo --from CalibrationDataDistortion``). In one run, interleaved (one round =
one run of each, so a busy machine slows both alike):

- ``python -m hdrfringe.cli phase FOLDER -o OUT --force``, a fresh process;
- ``python -m hdrfringe.cli measure FOLDER -c STEREO.h5 -o OUT --force``, a fresh process
  (decode, the direction check, triangulation, the dominant plane, the outputs).

``--baseline-src DIR`` adds the same two commands run with ``PYTHONPATH=DIR`` (an older
checkout's ``src``, native kernels built), in the same rounds: before and after in one run;
then every TIFF map both measurements wrote is compared (largest difference, pixels valid in
one only).

Each process's wall time and peak RSS (its own ``ru_maxrss``, from ``os.wait4``) are recorded;
printed are the medians of the wall times, the largest peak of each, and the ratios
measure / phase (issue 30's targets: wall at most 3, peak RSS at most 1 GB).

Then in this process, on the horizontal projector rows the measurement decoded
(``absolute_phase_horizontal.tiff``: the rows carry this rig's depth, ``measure`` keeps them):

- the library: ``triangulate_maps(calibration, v_proj=v)`` after a first call (so the camera's
  rays are cached, as in a measurement), its dominant-plane fit alone (``fit_dominant_plane``
  of the same points), and the triangulation alone (``stereo._triangulate_rays`` on the cached
  ray table; skipped by versions without one);
- the plain floor: numpy with the camera rays precomputed (``cv2.undistortPoints`` of every
  pixel, before timing) and the projector a pinhole: the plane of projector row ``v`` through
  the projector centre, ``lambda = -(n . t) / (n . R d)``, ``X = lambda d``: a handful of
  array operations per pixel. It ignores the projector's lens distortion, so it is a floor,
  not a replacement; its median distance to the library's points is printed.

The in-process cases are timed ``--repeats`` times, interleaved. Printed: the ratios of
``triangulate_maps`` and of the triangulation alone to the floor, and how far a float32 ray
table would move the rays (camera px) and the points (mm) from the float64 one.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
import tifffile

from hdrfringe.core import stereo
from hdrfringe.core.stereo import fit_dominant_plane, triangulate_maps
from hdrfringe.io.stereo_file import load_stereo_calibration

ROOT = Path(__file__).resolve().parents[1]
REALDATA = ROOT.parent / "shared" / "realdata" / "kimthyung_sphere"
DESCRIPTION = ROOT / "docs" / "examples" / "import" / "kimthyung_sphere.toml"
#: The horizontal fringes' pitch, projector rows (the description's; 10 periods over 1140).
PITCH = 114.0
#: Issue 30's targets for ``measure`` on this folder.
TARGET_RATIO, TARGET_RSS_GB = 3.0, 1.0


def prepare(tmp: Path) -> tuple[Path, Path]:
    """The imported capture folder and the converted stereo calibration."""
    cli = [sys.executable, "-m", "hdrfringe.cli"]
    caps, cal = tmp / "caps", tmp / "stereo.h5"
    quiet = {"check": True, "stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
    subprocess.run([*cli, "import", str(REALDATA), "-d", str(DESCRIPTION), "-o", str(caps)],
                   **quiet)  # type: ignore[call-overload]  # fmt: skip
    subprocess.run([*cli, "calibrate-stereo", "--from", str(REALDATA / "CalibrationDataDistortion"),
                    "-o", str(cal)], **quiet)  # type: ignore[call-overload]  # fmt: skip
    return caps, cal


def run_process(cmd: list[str], pythonpath: str | None = None) -> tuple[float, int]:
    """Wall time (s) and peak RSS (bytes) of one fresh process running ``cmd`` (with
    ``PYTHONPATH`` set to ``pythonpath`` when given)."""
    env = None if pythonpath is None else {**os.environ, "PYTHONPATH": pythonpath}
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed with exit code {proc.returncode}")
    return wall, int(usage.ru_maxrss) * 1024  # Linux: kilobytes


def plain_rays(
    camera_matrix: np.ndarray, distortion: np.ndarray, size: tuple[int, int]
) -> np.ndarray:
    """Every pixel's undistorted ray ``(x, y, 1)`` by OpenCV, (H*W, 3): the floor's precomputed
    table (not timed)."""
    width, height = size
    rows, cols = np.mgrid[0:height, 0:width].astype(np.float64)
    src = np.stack([cols.ravel(), rows.ravel()], axis=-1).reshape(-1, 1, 2)
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-10)
    iterative = getattr(cv2, "undistortPointsIter", None)  # OpenCV 4 takes criteria there
    if iterative is not None:
        xy = iterative(src, camera_matrix, distortion, None, None, crit)
    else:
        xy = cv2.undistortPoints(src, camera_matrix, distortion, criteria=crit)
    xy = np.asarray(xy).reshape(-1, 2)
    return np.c_[xy, np.ones(xy.shape[0])]


def plain_triangulation(
    rays: np.ndarray, v: np.ndarray, rotation: np.ndarray, t: np.ndarray, kp: np.ndarray
) -> np.ndarray:
    """The floor: camera rays against the pinhole plane of projector row ``v`` (numpy)."""
    a = rays @ rotation.T  # ray directions in the projector frame
    y = (v.ravel() - kp[1, 2]) / kp[1, 1]
    # the plane's normal (0, 1, -y) in the projector frame: n . X_p = 0, X_p = lam a + t
    lam = -(t[1] - y * t[2]) / (a[:, 1] - y * a[:, 2])
    return lam[:, None] * rays


def compare_maps(ours: Path, theirs: Path) -> dict[str, dict[str, float]]:
    """Every TIFF map both measurements wrote: the largest difference where both are finite
    and the pixels finite in only one."""
    out = {}
    for path in sorted(ours.glob("*.tiff")):
        other = theirs / path.name
        if other.exists():
            a = tifffile.imread(path).astype(np.float64)
            b = tifffile.imread(other).astype(np.float64)
            both = np.isfinite(a) & np.isfinite(b)
            diff = float(np.abs(a - b)[both].max()) if both.any() else 0.0
            out[path.name] = {
                "max_abs": diff,
                "valid_differs": int((np.isfinite(a) != np.isfinite(b)).sum()),
            }
    return out


def main() -> None:
    """Time the processes interleaved, then the triangulation against the floor; print."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--baseline-src", type=Path, default=None,
                    help="also run both commands with PYTHONPATH=DIR (e.g. an older checkout's "
                    "src), interleaved: before/after in one run")  # fmt: skip
    args = ap.parse_args()
    if not REALDATA.exists():
        print(f"skipped: the real captures are not here ({REALDATA}); nothing measured")
        return
    py = sys.executable
    result: dict[str, object] = {}
    with tempfile.TemporaryDirectory() as d:
        caps, cal = prepare(Path(d))
        out_p, out_m = Path(d) / "phase", Path(d) / "measure"
        cases = {
            "phase": [py, "-m", "hdrfringe.cli", "phase", str(caps), "-o", str(out_p), "--force"],
            "measure -c": [py, "-m", "hdrfringe.cli", "measure", str(caps), "-c", str(cal), "-o",
                           str(out_m), "--force"],
        }  # fmt: skip
        paths: dict[str, str | None] = dict.fromkeys(cases)
        if args.baseline_src is not None:
            for name in list(cases):
                out = str(Path(d) / f"{name.split()[0]}_baseline")  # its own outputs
                cases[f"{name} (baseline)"] = [
                    out if a == cases[name][-2] else a for a in cases[name]
                ]
                paths[f"{name} (baseline)"] = str(args.baseline_src.resolve())
        walls: dict[str, list[float]] = {k: [] for k in cases}
        peaks: dict[str, list[int]] = {k: [] for k in cases}
        for _ in range(args.repeats):
            for name, cmd in cases.items():
                wall, rss = run_process(cmd, paths[name])
                walls[name].append(wall)
                peaks[name].append(rss)
        phase = tifffile.imread(out_m / "absolute_phase_horizontal.tiff").astype(np.float64)
        if args.baseline_src is not None:
            result["maps_vs_baseline"] = compare_maps(out_m, Path(d) / "measure_baseline")
        calib = load_stereo_calibration(cal)

    v = PITCH * phase / (2 * np.pi)
    cam = calib.camera
    rays = plain_rays(cam.matrix, cam.distortion, cam.size)
    floor_args = (rays, v, calib.rotation, calib.translation_mm, calib.projector.matrix)
    maps = triangulate_maps(calib, v_proj=v)  # first call: the camera's rays computed, cached
    xyz = maps.xyz
    inner = getattr(stereo, "_triangulate_rays", None)  # the triangulation alone, if there
    table = stereo.ray_table(cam) if hasattr(stereo, "ray_table") else None
    lib = {
        "triangulate_maps": lambda: triangulate_maps(calib, v_proj=v),
        "plane fit": lambda: fit_dominant_plane(xyz),
        "floor": lambda: plain_triangulation(*floor_args),
    }
    if inner is not None and table is not None:
        flat = (table[0].reshape(-1), table[1].reshape(-1), None, v.reshape(-1), 1e-4, 50)
        lib["triangulation"] = lambda: inner(calib, *flat)
    seconds: dict[str, list[float]] = {k: [] for k in lib}
    outputs: dict[str, object] = {}
    for _ in range(args.repeats):  # interleaved, as the processes
        for name, fn in lib.items():
            t0 = time.perf_counter()
            outputs[name] = fn()
            seconds[name].append(time.perf_counter() - t0)
    t_in = {k: statistics.median(x) for k, x in seconds.items()}
    f32 = None
    if inner is not None and table is not None:  # the float32 table's effect on the points
        t32 = stereo.ray_table(cam, np.float32).astype(np.float64)
        x32, _ = inner(calib, t32[0].reshape(-1), t32[1].reshape(-1), None, v.reshape(-1), 1e-4, 50)
        ray_px = float(np.nanmax(np.abs(t32 - table)) * max(cam.matrix[0, 0], cam.matrix[1, 1]))
        f32 = {"ray_px": ray_px, "xyz_mm": float(np.nanmax(np.abs(x32 - xyz.reshape(-1, 3))))}
    floor_xyz = np.asarray(outputs["floor"]).reshape(xyz.shape)
    both = np.isfinite(xyz).all(-1) & np.isfinite(floor_xyz).all(-1)
    apart = float(np.median(np.linalg.norm(xyz[both] - floor_xyz[both], axis=-1)))

    med = {k: statistics.median(w) for k, w in walls.items()}
    peak = {k: max(p) for k, p in peaks.items()}
    print(f"{platform.machine()}, {os.cpu_count()} CPUs, Python {platform.python_version()}, "
          f"load average {os.getloadavg()[0]:.2f} at the end; kimthyung sphere "
          f"{cam.size[0]}x{cam.size[1]}, {args.repeats} interleaved rounds")  # fmt: skip
    head = f"{'wall s (median)':>16} {'(min':>7} {'max)':>7} {'peak RSS GB':>12}"
    print(f"  {'fresh process':<22} {head}")
    for k in cases:
        w = walls[k]
        print(f"  {k:<22} {med[k]:16.2f} {min(w):7.2f} {max(w):7.2f} {peak[k] / 1e9:12.3f}")
    if args.baseline_src is not None:
        base = ("measure -c (baseline)", "phase (baseline)")
        print(f"  baseline ({args.baseline_src}): measure / phase wall "
              f"{med[base[0]] / med[base[1]]:.2f}, peak RSS {peak[base[0]] / peak[base[1]]:.2f}; "
              f"measure now / baseline: wall {med['measure -c'] / med[base[0]]:.2f}, peak RSS "
              f"{peak['measure -c'] / peak[base[0]]:.2f}")  # fmt: skip
    maps = result.get("maps_vs_baseline")
    if isinstance(maps, dict) and maps:
        moved = {k: v for k, v in maps.items() if v["max_abs"] or v["valid_differs"]}
        said = [f"{k} max {v['max_abs']:.2g}, {v['valid_differs']} px valid in one only"
                for k, v in moved.items()]  # fmt: skip
        print(f"  measure's maps against the baseline's: {len(maps) - len(moved)} of "
              f"{len(maps)} identical; " + "; ".join(said))  # fmt: skip
    ratio_wall = med["measure -c"] / med["phase"]
    ratio_rss = peak["measure -c"] / peak["phase"]
    print(f"  measure / phase: wall {ratio_wall:.2f} (target <= {TARGET_RATIO:g}), peak RSS "
          f"{ratio_rss:.2f}; measure peak {peak['measure -c'] / 1e9:.3f} GB (target <= "
          f"{TARGET_RSS_GB:g} GB)")  # fmt: skip
    print(f"  in process, median of {args.repeats} interleaved calls (s): "
          + ", ".join(f"{k} {t:.3f}" for k, t in t_in.items()))  # fmt: skip
    ratios = {"triangulate_maps / floor": t_in["triangulate_maps"] / t_in["floor"]}
    if "triangulation" in t_in:
        ratios["triangulation / floor"] = t_in["triangulation"] / t_in["floor"]
    print("  " + ", ".join(f"{k} {r:.2f}" for k, r in ratios.items())
          + f"; median distance floor - library {apart:.3f} mm (the floor ignores the "
          "projector's distortion)")  # fmt: skip
    if f32 is not None:
        print(f"  float32 ray table against float64: rays {f32['ray_px']:.1e} camera px, points "
              f"{f32['xyz_mm']:.1e} mm at most")  # fmt: skip
    result = {
        **result,
        "wall_s": walls, "peak_rss_bytes": peaks, "median_wall_s": med, "peak_rss_max": peak,
        "measure_over_phase": {"wall": ratio_wall, "peak_rss": ratio_rss},
        "in_process_s": seconds, "in_process_median_s": t_in, "ratios_to_floor": ratios,
        "floor_distance_median_mm": apart, "float32_table": f32,
    }  # fmt: skip
    if args.json:
        args.json.write_text(json.dumps(result))


if __name__ == "__main__":
    main()
