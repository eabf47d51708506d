"""Benchmark: exposure alone (multi-exposure), MIGL alone, and an automatic exposure + MIGL.

Run ``.venv/bin/python benchmarks/bench_exposure.py`` (about a minute; ``--quick``: half the
camera resolution, a few seconds; ``--json PATH`` also writes the rows). See
docs/multiexposure.md for the results and what they mean.

Scenes of the virtual rig (default camera 648 x 494, noise on, no ambient light): the
checkerboard (black-plate aperture, thesis Sec. 5.2.2) and the specular metal part (white-plate
aperture, highlight about 50x its diffuse level). One sinusoidal 4-step set of pitch 8 px
(16 px with ``--quick``), vertical fringes, imin 40, MIGL 255. Methods:

* ``conventional``: one set at the rig's exposure (10 ms);
* ``uniform auto``, ``LPA S=15``: MIGL alone, at the rig's exposure (thesis Ch. 4-5);
* ``multi-exposure auto x2``: exposure alone (Zhang & Yau 2009, :mod:`hdrfringe.strategies.
  multiexposure`);
* ``auto exposure + uniform``, ``auto exposure + LPA S=15``: the exposure chosen for the
  darkest surface (:func:`hdrfringe.strategies.exposure.choose_exposure`, thesis Sec. 7.3),
  then the MIGL strategy at that exposure (its first set reused from the choice);
* ``noise-free floor``: the rig's noise-free signal of the set, decoded without clipping: the
  error the optics alone leave (camera blur across reflectivity edges and the highlight).

Reported per method: images captured (the choice's included), coverage (valid decoded pixels
among the rig's valid pixels: no saturated shift, modulation at least 2 DN), the phase error
(decoded wrapped phase minus the known ``2 pi u / p`` from ``GroundTruth.u``, wrapped to
(-pi, pi]) as standard deviation and mean over the covered pixels; "noise": the standard
deviation of the decoded phase minus the noise-free floor's (what the method's noise and
residual clipping add to the optics' own error); and the coverage and phase-error standard
deviation over the pixels the conventional set clips (the hard ones).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.phase import decode_set, sinusoidal_phase
from hdrfringe.rig.factory import virtual_rig
from hdrfringe.rig.simulated import SimulatedRig
from hdrfringe.strategies import StrategyResult
from hdrfringe.strategies.conventional import conventional
from hdrfringe.strategies.exposure import run_at_exposure
from hdrfringe.strategies.lpa import lpa
from hdrfringe.strategies.multiexposure import multiexposure
from hdrfringe.strategies.uniform import uniform

SCENES = ("checkerboard", "specular_part")


def _methods() -> dict[str, Callable[[SimulatedRig, FringeSpec], tuple[StrategyResult, int, str]]]:
    """Method label -> run(rig, spec) -> (result, images captured, note)."""

    def plain(fn: Callable[..., StrategyResult], **kw: Any) -> Callable[..., Any]:
        def run(rig: SimulatedRig, spec: FringeSpec) -> tuple[StrategyResult, int, str]:
            res = fn(rig, spec, **kw)
            note = ""
            if res.strategy == "uniform":
                note = f"MIGL {res.details['chosen_migl']:g}"
            elif res.strategy == "lpa":
                note = f"MIGL {min(res.migls):g}..255"
            elif res.strategy == "multiexposure":
                ts = res.details["exposures_ms"]
                note = f"{min(ts):g}..{max(ts):g} ms"
            return res, res.images_captured, note

        return run

    def at_exposure(method: str, params: dict[str, Any]) -> Callable[..., Any]:
        def run(rig: SimulatedRig, spec: FringeSpec) -> tuple[StrategyResult, int, str]:
            choice, res, images = run_at_exposure(rig, spec, method, params)
            low = res.details.get("chosen_migl", min(s.migl or 255.0 for s in res.captured))
            return res, images, f"{choice.exposure_ms:g} ms, MIGL {low:g}"

        return run

    return {
        "conventional": plain(conventional),
        "uniform auto": plain(uniform),
        "LPA S=15": plain(lpa, step=15.0),
        "multi-exposure auto x2": plain(multiexposure),
        "auto exposure + uniform": at_exposure("uniform", {}),
        "auto exposure + LPA S=15": at_exposure("lpa", {"step": 15.0}),
    }


def _errors(phase: np.ndarray, truth_u: np.ndarray, pitch: float) -> np.ndarray:
    return np.angle(np.exp(1j * (phase - 2 * np.pi * truth_u / pitch)))


def bench_scene(
    scene: str, resolution: tuple[int, int] | None, pitch: float, seed: int
) -> list[dict]:
    """Every method on one scene; a fresh rig (same seed) per method."""
    spec = FringeSpec("sinusoidal", 4, pitch)
    make = lambda: virtual_rig(scene, resolution=resolution, seed=seed)  # noqa: E731
    truth = make().truth()
    valid = truth.valid
    hard = np.zeros_like(valid)  # the pixels the conventional set (run first) clips
    floor, _, _ = sinusoidal_phase(make().expected_signal(spec.frames()))
    rows: list[dict] = []
    for label, run in _methods().items():
        t0 = time.perf_counter()
        res, images, note = run(make(), spec)
        seconds = time.perf_counter() - t0
        if label == "conventional":
            hard = res.never_unsaturated & valid
        dec = decode_set(res.images, spec, make().camera_bit_depth)
        rows.append(_row(scene, label, images, note, dec, floor, truth, hard, pitch, seconds))
    rows.append(_row(scene, "noise-free floor", 0, "", None, floor, truth, hard, pitch, 0.0))
    return rows


def _row(
    scene: str,
    label: str,
    images: int,
    note: str,
    dec: Any,
    floor: np.ndarray,
    truth: Any,
    hard: np.ndarray,
    pitch: float,
    seconds: float,
) -> dict:
    ok = truth.valid if dec is None else dec.valid
    phase = floor if dec is None else dec.wrapped_phase
    covered = ok & truth.valid
    err = _errors(phase, truth.u, pitch)
    noise = np.angle(np.exp(1j * (phase - floor)))
    on_hard = covered & hard
    return {
        "scene": scene,
        "method": label,
        "images": int(images),
        "coverage": float(covered.sum() / truth.valid.sum()),
        "std_mrad": float(1e3 * np.std(err[covered])),
        "mean_mrad": float(1e3 * np.mean(err[covered])),
        "noise_mrad": float(1e3 * np.std(noise[covered])),
        "hard_std_mrad": float(1e3 * np.std(err[on_hard])) if on_hard.any() else float("nan"),
        "hard_coverage": float(on_hard.sum() / max(int(hard.sum()), 1)),
        "note": note,
        "seconds": seconds,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="324 x 247 camera, pitch 16")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", type=Path, default=None, help="also write the rows here")
    args = ap.parse_args(argv)
    resolution, pitch = ((324, 247), 16.0) if args.quick else (None, 8.0)
    rows = [r for s in SCENES for r in bench_scene(s, resolution, pitch, args.seed)]
    head = (
        f"{'scene':14} {'method':26} {'images':>6} {'cover %':>8} {'std mrad':>9} "
        f"{'mean mrad':>10} {'noise mrad':>10} {'clipped@10ms: cover %':>22} {'std mrad':>9}  note"
    )
    print(head)
    print("-" * len(head))
    for r in rows:
        print(
            f"{r['scene']:14} {r['method']:26} {r['images']:6d} {100 * r['coverage']:8.2f} "
            f"{r['std_mrad']:9.1f} {r['mean_mrad']:10.1f} {r['noise_mrad']:10.1f} "
            f"{100 * r['hard_coverage']:22.1f} "
            f"{r['hard_std_mrad']:9.1f}  {r['note']}"
        )
    if args.json is not None:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
