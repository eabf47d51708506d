"""Benchmark: where the acceptance's PS/SD bias came from, and what the edge rules leave.

Run ``.venv/bin/python benchmarks/bench_acceptance_bias.py`` (options below). For every
sphere and ball-bar position of the virtual rig's plan (``--positions``, as for
``hdrfringe acceptance``), the position is captured once (conventional, the acceptance's
fringes) and evaluated by :func:`hdrfringe.tasks.acceptance.evaluate_cloud`:

- ``rules``: with the edge rules (:data:`~hdrfringe.tasks.acceptance.MAX_VIEW_DEG`,
  :data:`~hdrfringe.tasks.acceptance.BALL_BAR_NECK_DEG`) and without them (the rules before
  issue 25's fix), each against the std predicted from the phase noise;
- ``--calibration``: ``true`` (the rig's own geometry: no calibration error), a stereo
  calibration file, or ``seeds:0,1,...``: ``calibrate-stereo --rig sim`` with those noise
  seeds (the captures triangulated again with each; the spread over the seeds is the
  calibration's contribution to PS/SD, printed beside the phase-noise std);
- ``--noise 0``: the captures without image noise (what the optics alone do);
- ``--no-blur``: no camera blur and no projector defocus.

Prints one table row per position: value (mm), predicted std (mm), value / std, for each rule.
docs/acceptance.md ("Edge rules") states the numbers of the runs it names.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from hdrfringe.tasks.acceptance import DEFAULT_BOARD, parse_size


def _calibrations(spec: str, size: tuple[int, int], rig: Any) -> list[tuple[str, Any]]:
    from hdrfringe.io.stereo_file import load_stereo_calibration
    from hdrfringe.tasks.calibrate_stereo import calibrate_stereo

    if spec == "true":
        return [("true", rig.stereo_calibration())]
    if not spec.startswith("seeds:"):
        return [(Path(spec).name, load_stereo_calibration(Path(spec)))]
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in (int(s) for s in spec[6:].split(",")):
            done = calibrate_stereo(
                Path(tmp) / f"cal_{seed}.h5",
                rig="sim",
                board=DEFAULT_BOARD,
                seed=seed,
                camera_size=size,
            )
            out.append((f"seed {seed}", done.calibration))
    return out


def main(argv: list[str] | None = None) -> int:
    """Measure every sphere and ball-bar position, print the table.

    Parameters
    ----------
    argv : list of str, optional
        Command-line arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit code.
    """
    from hdrfringe.core.programs import fringe_specs
    from hdrfringe.errors import InputError
    from hdrfringe.pipeline import measure
    from hdrfringe.rig.board_poses import calibration_rig
    from hdrfringe.rig.scenes import white_plate
    from hdrfringe.tasks.acceptance import (
        DEFAULT_PITCHES,
        STEPS,
        _chosen,
        _plan,
        _point_std,
        _sidecar,
        evaluate_cloud,
    )

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="640x480", help="camera WIDTHxHEIGHT")
    ap.add_argument("--positions", default="sphere,ball_bar", help="as --positions")
    ap.add_argument("--calibration", default="true", help="true, FILE or seeds:0,1,...")
    ap.add_argument("--noise", type=float, default=1.0, help="read noise, DN")
    ap.add_argument("--no-blur", action="store_true", help="no camera blur, no defocus")
    args = ap.parse_args(argv)
    size = parse_size(args.size)
    plan, artefacts = _plan(size, False, None)
    cals = _calibrations(args.calibration, size, calibration_rig(white_plate(), camera_size=size))
    specs = fringe_specs("sinusoidal", STEPS, list(DEFAULT_PITCHES))
    rules = {"edge rules": {}, "no edge rules": {"max_view_deg": None, "neck_deg": None}}
    print(f"camera {size[0]}x{size[1]}, noise {args.noise} DN, blur {not args.no_blur}")
    head = " | ".join(f"{r}: value / std / ratio" for r in rules)
    print(f"| position | calibration | {head} |")
    for pos in _chosen(plan, args.positions, artefacts):
        rig = calibration_rig(pos.scene, camera_size=size, noise=args.noise)
        if args.no_blur:
            rig = rig.replace(
                camera=dataclasses.replace(rig.camera, blur_px=0.0),
                projector_model=dataclasses.replace(rig.projector_model, defocus_px=0.0),
            )
        first = measure(rig, cals[0][1], specs=specs, strategy="conventional")
        sidecar = _sidecar(pos, "conventional", rig)
        q = "PS" if pos.kind == "sphere" else "SD"
        per_rule: dict[str, list[float]] = {r: [] for r in rules}
        for name, cal in cals:
            res = first if name == cals[0][0] else measure(first.captures, cal)
            phase_std = first.uncertainty.phase_std if first.uncertainty is not None else None
            pitch = float(first.decoded.primary.pitch_px)
            std = None
            if phase_std is not None:
                std = _point_std(res.stereo.xyz, phase_std, pitch, cal)
            cells = []
            for rule, kw in rules.items():
                try:
                    values, details, _ = evaluate_cloud(
                        res.stereo.xyz,
                        pos.kind,
                        artefacts,
                        expected=sidecar["expected"],
                        point_std=std,
                        **kw,
                    )
                except InputError as err:  # not found: say so, go on
                    cells.append(f"not found ({str(err)[:60]}...)")
                    per_rule[rule].append(float("nan"))
                    continue
                v = values[q]
                s = details.get("predicted_std_mm", {}).get(q)
                per_rule[rule].append(v)
                ratio = "—" if not s else f"{v / s:+.1f}"
                cells.append(f"{v:+.4f} / {'—' if s is None else f'{s:.4f}'} / {ratio}")
            print(f"| {pos.label} {q} | {name} | " + " | ".join(cells) + " |", flush=True)
        if len(cals) > 1:
            spread = " | ".join(
                f"std over calibrations {np.std(v, ddof=1):.4f}" for v in per_rule.values()
            )
            print(f"| {pos.label} {q} | spread | {spread} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
