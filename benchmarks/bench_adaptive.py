"""Benchmark: per-pixel adaptive projection against LPA S=1 and DPA with the pending bound.

Run ``.venv/bin/python benchmarks/bench_adaptive.py`` (``--camera 160x120`` for the small
camera of the tests, ``--json PATH`` to keep the numbers). See docs/adaptive.md.

For each scene every strategy measures the same three vertical sets (4-step, pitches 1024,
64 and 8 px, the CLI's default) on a fresh virtual rig; the composite goes through the
product's decoder and temporal unwrapping (:func:`hdrfringe.core.decode.decode_captures`). The
phase error is the absolute phase of the 8 px set minus the known one, ``2 pi u / 8`` from
the rig's ground truth, over the pixels the truth calls valid; the table gives the images
captured, the error's mean (bias) and standard deviation, its RMSE and the coverage (valid
pixels with an absolute phase).

``--topup`` compares, on the specular part only, adaptive with and without its coverage
top-up against LPA S=1 where both are valid (docs/adaptive.md, "Top-up"), then prints the
top-up's details on the checkerboard, the 600 lx plate and the glossy dome, where it must
not run.

Scenes: the checkerboard with the aperture opened for the black squares (the thesis's
Sec. 5.2 board) and the white plate under 600 lx (Sec. 4.2). Rows: LPA S=1, DPA 10 % with the
pending bound, adaptive, adaptive without its boost set, adaptive with the automatic exposure;
``--study`` adds adaptive with the boost's radius fraction and the map-bias threshold varied
(docs/adaptive.md).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from hdrfringe.core.decode import decode_captures
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.pipeline import composite_captures, strategy_absolute_phases
from hdrfringe.rig.scenes import BLACK_PLATE_REFLECTIVITY, checkerboard, white_plate
from hdrfringe.rig.simulated import CameraModel, Lighting, SimulatedRig
from hdrfringe.strategies.adaptive import adaptive_sets
from hdrfringe.tasks.compare import SCENES as COMPARE_SCENES

PITCHES = (1024.0, 64.0, 8.0)
STRATEGIES: tuple[tuple[str, str, dict[str, Any]], ...] = (
    ("LPA S=1", "lpa", {"step": 1.0}),
    ("DPA 10 % + bound", "dpa", {"threshold": 0.1, "bound_pending": True}),
    ("Adaptive", "adaptive", {}),
    ("Adaptive, no boost", "adaptive", {"boost": False}),
    ("Adaptive + exposure", "adaptive", {"auto_exposure": True}),
)
#: ``--study``: the boost's radius fraction and the bias correction's threshold, varied
#: (module constants of :mod:`hdrfringe.strategies.adaptive`) with the label's parameters.
STUDY: tuple[tuple[str, dict[str, Any], dict[str, float]], ...] = (
    ("boost radius x0.25", {}, {"BOOST_RADIUS_FRACTION": 0.25}),
    ("boost radius x0.75", {}, {"BOOST_RADIUS_FRACTION": 0.75}),
    ("boost radius x1", {}, {"BOOST_RADIUS_FRACTION": 1.0}),
    ("no bias correction", {"bias_correction": False}, {}),
    ("bias corr. >= 0", {}, {"BIAS_MIN_RAD": 0.0}),
)


def checkerboard_rig(width: int, height: int, seed: int = 0) -> SimulatedRig:
    """The checkerboard, aperture opened so the black squares reach 85 % of full scale."""
    rig = SimulatedRig(checkerboard(), camera=CameraModel(width=width, height=height), seed=seed)
    return rig.replace(camera=rig.camera.with_aperture_for(BLACK_PLATE_REFLECTIVITY))


def plate_600lx_rig(width: int, height: int, seed: int = 0) -> SimulatedRig:
    """The white plate with 600 lx of ambient light (thesis Sec. 4.2)."""
    return SimulatedRig(
        white_plate(),
        camera=CameraModel(width=width, height=height),
        lighting=Lighting(ambient_lux=600),
        seed=seed,
    )


SCENES: dict[str, Callable[..., SimulatedRig]] = {
    "checkerboard": checkerboard_rig,
    "plate 600 lx": plate_600lx_rig,
}


def error_map(
    rig: SimulatedRig, method: str, params: dict[str, Any]
) -> tuple[np.ndarray, np.ndarray, list[Any], float]:
    """Measure with ``method``: the finest absolute phase minus the truth, the pixels valid in
    the truth with a phase, the strategy results and the seconds taken."""
    specs = [FringeSpec("sinusoidal", 4, p) for p in PITCHES]
    t0 = time.perf_counter()
    caps, results = composite_captures(rig, specs, method, params)
    seconds = time.perf_counter() - t0
    decoded = decode_captures(caps, given_phases=strategy_absolute_phases(results))
    fam = decoded.primary
    assert fam is not None and fam.absolute_phase is not None
    truth = rig.truth()
    err = fam.absolute_phase - 2 * np.pi * truth.u / PITCHES[-1]
    return err, truth.valid & np.isfinite(err), results, seconds


def phase_error(rig: SimulatedRig, method: str, params: dict[str, Any]) -> dict[str, Any]:
    """Measure with ``method`` and compare the finest absolute phase with the ground truth."""
    err, ok, results, seconds = error_map(rig, method, params)
    e = err[ok]
    return {
        "images": int(sum(r.images_captured for r in results)),
        "sets": int(sum(r.sets_captured for r in results)),
        "bias_rad": float(e.mean()),
        "std_rad": float(e.std()),
        "rmse_rad": float(np.sqrt(np.mean(e**2))),
        "coverage": float(ok.sum() / rig.truth().valid.sum()),
        "seconds": round(seconds, 2),
        "details": {**results[-1].details, "absolute_phase": results[-1].absolute_phase},
    }


def run(width: int, height: int, study: bool = False) -> dict[str, dict[str, dict[str, Any]]]:
    """Every strategy on every scene: ``{scene: {label: numbers}}`` (and the study's rows)."""
    import hdrfringe.strategies.adaptive as adaptive_module

    out: dict[str, dict[str, dict[str, Any]]] = {}
    for scene, make in SCENES.items():
        out[scene] = {}
        for label, method, params in STRATEGIES:
            out[scene][label] = phase_error(make(width, height), method, params)
        for label, params, constants in STUDY if study else ():
            saved = {k: getattr(adaptive_module, k) for k in constants}
            try:
                for k, v in constants.items():
                    setattr(adaptive_module, k, v)
                out[scene][label] = phase_error(make(width, height), "adaptive", params)
            finally:
                for k, v in saved.items():
                    setattr(adaptive_module, k, v)
    return out


def specular_breakdown(width: int, height: int) -> list[tuple[str, int, float]]:
    """Adaptive on the specular part: phase-error std by distance (camera px) to the pixels
    it leaves uncovered without its top-up (the highlight), ``(band, pixels, std rad)``;
    then without the bias correction, with the top-up, and on the pixels the top-up adds."""
    from scipy import ndimage

    from hdrfringe.rig.factory import virtual_rig

    # the highlight: what adaptive leaves uncovered without its top-up
    rig = virtual_rig("specular_part", resolution=(width, height), seed=0)
    r = phase_error(rig, "adaptive", {"topup": False})
    truth = rig.truth()
    err = r["details"]["absolute_phase"] - 2 * np.pi * truth.u / PITCHES[-1]
    ok = truth.valid & np.isfinite(err)
    dist = ndimage.distance_transform_edt(ok | ~truth.valid)
    out = [("all", int(ok.sum()), float(err[ok].std()))]
    for lo, hi in ((0, 3), (3, 10), (10, 30), (30, np.inf)):
        m = ok & (dist >= lo) & (dist < hi)
        out.append((f"{lo}-{hi} px", int(m.sum()), float(err[m].std())))
    # the same without the map-bias correction (docs/adaptive.md, step 4)
    rig = virtual_rig("specular_part", resolution=(width, height), seed=0)
    r = phase_error(rig, "adaptive", {"bias_correction": False, "topup": False})
    err = r["details"]["absolute_phase"] - 2 * np.pi * truth.u / PITCHES[-1]
    ok = truth.valid & np.isfinite(err)
    out.append(("all, no bias correction", int(ok.sum()), float(err[ok].std())))
    # with the top-up (the default): the field, and the pixels it adds
    rig = virtual_rig("specular_part", resolution=(width, height), seed=0)
    r = phase_error(rig, "adaptive", {})
    err_t = r["details"]["absolute_phase"] - 2 * np.pi * truth.u / PITCHES[-1]
    ok_t = truth.valid & np.isfinite(err_t)
    out.append(("all, with top-up", int(ok_t.sum()), float(err_t[ok_t].std())))
    added = ok_t & (dist == 0)
    out.append(("top-up adds", int(added.sum()), float(err_t[added].std())))
    return out


#: ``--topup``: the rows on the specular part (label, method, params).
TOPUP_ROWS: tuple[tuple[str, str, dict[str, Any]], ...] = (
    ("LPA S=1", "lpa", {"step": 1.0}),
    ("adaptive, no top-up", "adaptive", {"topup": False}),
    ("adaptive", "adaptive", {}),
    ("adaptive + exposure, no top-up", "adaptive", {"auto_exposure": True, "topup": False}),
    ("adaptive + exposure", "adaptive", {"auto_exposure": True}),
)


#: ``--epipolar``: one mapping direction + the epipolar constraint and the full-MIGL mapping
#: on the specular part, one at a time and together (docs/adaptive.md), beside LPA S=1.
EPIPOLAR_ROWS: tuple[tuple[str, str, dict[str, Any]], ...] = (
    ("LPA S=1", "lpa", {"step": 1.0}),
    ("adaptive", "adaptive", {}),
    ("adaptive, epipolar", "adaptive", {"epipolar": True}),
    ("adaptive, full mapping", "adaptive", {"full_mapping": True}),
    ("adaptive, epipolar + full mapping", "adaptive", {"epipolar": True, "full_mapping": True}),
    # the full-MIGL mapping with the refit, check and boost sets kept (a given mapping MIGL:
    # no bright ladder either), to show what skipping them does
    (
        "epipolar, MIGL 255 mapping + refit etc.",
        "adaptive",
        {"epipolar": True, "mapping_migl": 255.0},
    ),
    (
        "epipolar + full mapping + exposure",
        "adaptive",
        {"epipolar": True, "full_mapping": True, "auto_exposure": True},
    ),
)


def topup_study(
    width: int,
    height: int,
    rows: tuple[tuple[str, str, dict[str, Any]], ...] = TOPUP_ROWS,
    scene: str = "specular_part",
) -> list[dict[str, Any]]:
    """The coverage top-up on the specular part (docs/adaptive.md, "Top-up"), each row on a
    fresh rig (seed 0): images, coverage, std and std in order (|error| <= pi), and the std
    over the pixels where the row and LPA S=1 are both valid and in order, beside LPA's there.
    ``rows`` (the first must be LPA S=1) and ``scene`` (a name of
    :data:`hdrfringe.tasks.compare.SCENES`; ``--epipolar``) change what is run.
    """
    from hdrfringe.rig.factory import virtual_rig

    out: list[dict[str, Any]] = []
    ref: tuple[np.ndarray, np.ndarray] | None = None
    for label, method, params in rows:
        rig = virtual_rig(resolution=(width, height), seed=0, **COMPARE_SCENES[scene])
        err, ok, results, seconds = error_map(rig, method, params)
        good = ok & (np.abs(np.where(ok, err, 0.0)) <= np.pi)
        if ref is None:
            ref = (err, good)
        both = good & ref[1]
        d = results[-1].details
        out.append(
            {
                "label": label,
                "images": int(sum(r.images_captured for r in results)),
                "coverage": float(ok.sum() / rig.truth().valid.sum()),
                "std_rad": float(err[ok].std()),
                "std_in_order_rad": float(err[good].std()),
                "both_px": int(both.sum()),
                "std_both_rad": float(err[both].std()),
                "lpa_std_both_rad": float(ref[0][both].std()),
                "topup": d.get("topup"),
                "images_per_step": d.get("images_per_step"),
                "full_mapping": d.get("full_mapping"),
                "exposure_ms": d.get("exposure_ms"),
                "seconds": round(seconds, 1),
            }
        )
    return out


#: ``--draws``: adaptive and adaptive with epipolar + full mapping (label, params).
DRAW_ROWS: tuple[tuple[str, dict[str, Any]], ...] = (
    ("adaptive", {}),
    ("adaptive, no bias corr.", {"bias_correction": False}),
    ("epipolar + full mapping", {"epipolar": True, "full_mapping": True}),
    (
        "the same, no bias corr.",
        {"epipolar": True, "full_mapping": True, "bias_correction": False},
    ),
)


def draw_study(width: int, height: int, scene: str) -> list[tuple[str, str, float]]:
    """How the std in order depends on the noise draw: each row on fresh rigs of seeds 0-3,
    then three times in a row on one rig of seed 0 (each run draws new noise for the frames it
    repeats, as the compare's shared rig does). ``(label, draw, std rad)``."""
    from hdrfringe.pipeline import measure
    from hdrfringe.rig.factory import virtual_rig

    specs = [FringeSpec("sinusoidal", 4, p) for p in PITCHES]

    def std_of(rig: SimulatedRig, params: dict[str, Any]) -> float:
        res = measure(rig, strategy="adaptive", params=params, specs=specs)
        err = res.decoded.primary.absolute_phase - 2 * np.pi * rig.truth().u / PITCHES[-1]
        ok = rig.truth().valid & np.isfinite(err)
        return float(err[ok & (np.abs(np.where(ok, err, 0.0)) <= np.pi)].std())

    out = []
    for label, params in DRAW_ROWS:
        for seed in range(4):
            rig = virtual_rig(resolution=(width, height), seed=seed, **COMPARE_SCENES[scene])
            out.append((label, f"seed {seed}", std_of(rig, params)))
        rig = virtual_rig(resolution=(width, height), seed=0, **COMPARE_SCENES[scene])
        for k in range(3):
            out.append((label, f"seed 0, run {k + 1} on one rig", std_of(rig, params)))
    return out


def topup_elsewhere(width: int, height: int) -> list[tuple[str, bool, dict[str, Any]]]:
    """The top-up's details on the scenes where it must not run (checkerboard, 600 lx plate,
    glossy dome; with and without the automatic exposure): ``(scene, auto_exposure, topup)``.
    """
    from hdrfringe.rig.factory import virtual_rig

    specs = [FringeSpec("sinusoidal", 4, p) for p in PITCHES]
    out = []
    for scene, kw in (
        ("checkerboard", {}),
        ("white_plate", {"ambient_lux": 600.0}),
        ("glossy", {}),
    ):
        for auto in (False, True):
            rig = virtual_rig(scene, resolution=(width, height), seed=0, **kw)
            fine = adaptive_sets(rig, specs, auto_exposure=auto)[-1]
            out.append((scene, auto, fine.details["topup"]))
    return out


def main(argv: list[str] | None = None) -> int:
    """Print (and optionally save) the comparison table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--camera", default="648x494", help="camera WIDTHxHEIGHT (default 648x494)")
    ap.add_argument("--json", default=None, help="also write the numbers to this JSON file")
    ap.add_argument("--study", action="store_true", help="also the boost/bias variants")
    ap.add_argument(
        "--specular",
        action="store_true",
        help="only: adaptive's error by distance to the highlight",
    )
    ap.add_argument(
        "--epipolar",
        action="store_true",
        help="only: one mapping direction + the epipolar constraint and the full-MIGL mapping "
        "against LPA S=1 (the specular part, then the checkerboard and the 600 lx plate)",
    )
    ap.add_argument(
        "--draws",
        default=None,
        metavar="SCENE",
        help="only: adaptive and epipolar + full mapping over noise draws on SCENE (a compare "
        "scene: checkerboard, specular_part, ...)",
    )
    ap.add_argument(
        "--topup",
        action="store_true",
        help="only: the coverage top-up on the specular part against LPA S=1",
    )
    args = ap.parse_args(argv)
    width, height = (int(x) for x in args.camera.lower().split("x"))
    if args.draws:
        print(f"{args.draws}, camera {width}x{height}, std in order by noise draw")
        for label, draw, std in draw_study(width, height, args.draws):
            print(f"  {label:26} {draw:26} {1e3 * std:7.2f} mrad")
        return 0
    if args.epipolar:
        print(f"camera {width}x{height}, 4-step, pitches 1024, 64, 8 px, seed 0")
        for scene in ("specular_part", "checkerboard", "white_plate_600lx"):
            print(scene)
            rows = EPIPOLAR_ROWS if scene == "specular_part" else EPIPOLAR_ROWS[:5]
            for r in topup_study(width, height, rows, scene):
                both = r["std_both_rad"] / r["lpa_std_both_rad"]
                print(
                    f"  {r['label']:36} {r['images']:5d} img  coverage "
                    f"{100 * r['coverage']:6.2f} %  in order {1e3 * r['std_in_order_rad']:6.2f}"
                    f"  both valid ({r['both_px']} px) {1e3 * r['std_both_rad']:6.2f} mrad"
                    f" = {both:.3f}x LPA's  {r['seconds']:6.1f} s  {r['images_per_step']}"
                    f"  {r['full_mapping']}"
                )
        return 0
    if args.topup:
        print(f"specular part, camera {width}x{height}, 4-step, pitches 1024, 64, 8 px, seed 0")
        for r in topup_study(width, height):
            both = r["std_both_rad"] / r["lpa_std_both_rad"]
            print(
                f"  {r['label']:32} {r['images']:5d} img  coverage {100 * r['coverage']:6.2f} %"
                f"  std {1e3 * r['std_rad']:7.2f}  in order {1e3 * r['std_in_order_rad']:6.2f}"
                f"  where both valid ({r['both_px']} px) {1e3 * r['std_both_rad']:6.2f} mrad"
                f" = {both:.3f}x LPA's  {r['seconds']:6.1f} s  top-up {r['topup']}"
            )
        for scene, auto, topup in topup_elsewhere(width, height):
            print(f"  {scene}{' + exposure' if auto else ''}: top-up {topup}")
        return 0
    if args.specular:
        print(f"specular part, adaptive, camera {width}x{height}: std by distance to uncovered")
        for band, n, std in specular_breakdown(width, height):
            print(f"  {band:>24} {n:8d} px  std {std:.4f} rad")
        return 0
    table = run(width, height, args.study)
    print(f"camera {width}x{height}, 4-step, pitches {', '.join(f'{p:g}' for p in PITCHES)} px")
    head = f"{'scene':14} {'strategy':20} {'images':>6} {'bias':>9} {'std':>8} {'RMSE':>8} "
    print(head + f"{'coverage':>9} {'time s':>7}")
    for scene, rows in table.items():
        for label, r in rows.items():
            print(
                f"{scene:14} {label:20} {r['images']:6d} {r['bias_rad']:9.5f} "
                f"{r['std_rad']:8.5f} {r['rmse_rad']:8.5f} {r['coverage']:9.4f} "
                f"{r['seconds']:7.2f}"
            )
        lpa, dpa = rows["LPA S=1"], rows["DPA 10 % + bound"]
        for name in ("Adaptive", "Adaptive + exposure"):
            ad = rows[name]
            print(
                f"{'':14} {name}/LPA std {ad['std_rad'] / lpa['std_rad']:.3f}, images "
                f"{ad['images']}/{dpa['images']} of DPA+bound = "
                f"{ad['images'] / dpa['images']:.3f}; steps {ad['details']['images_per_step']}, "
                f"s {ad['details']['seconds_per_step']}"
            )
    if args.json:
        for rows in table.values():
            for r in rows.values():
                r.pop("details")
        with open(args.json, "w") as fh:
            json.dump(table, fh, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
