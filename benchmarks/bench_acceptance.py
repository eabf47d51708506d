"""Benchmark: the full acceptance procedure on the virtual rig, and the HDR table.

Run ``.venv/bin/python benchmarks/bench_acceptance.py -o DIR`` (or ``make bench-acceptance``):

1. ``DIR/matte``: ``hdrfringe acceptance --rig sim`` with the conventional strategy over all
   23 positions (10 sphere, 7 ball bar, 6 plane; matte artefacts) at ``--size`` (default
   640 x 480), the rig calibrated first by ``calibrate-stereo --rig sim`` (kept as
   ``DIR/matte/calibration.h5``). Prints the wall time, each position's values, and PS and SD
   against the ground truth (the calibrated values are the virtual artefacts' own sizes, so
   PS and SD *are* the errors) beside the predicted std: the phase noise's
   (:mod:`hdrfringe.core.acceptance_noise`) and the calibration's (the spread over the run's
   calibration and :data:`~hdrfringe.tasks.acceptance.CALIBRATION_REPEATS` more), combined.
2. ``DIR/glossy``: the glossy sphere at its 10 positions measured by every strategy of
   ``--strategies`` with that calibration: the HDR table (PF, PS, images; pass/fail against
   the MPEs of :data:`hdrfringe.tasks.acceptance.SIM_MPES`).

The machine may be shared: the wall time is the run's, not a speed claim against a baseline.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from hdrfringe.tasks.acceptance import AcceptanceReport, acceptance_sim, parse_size

STRATEGIES = "conventional,uniform,lpa-5,dpa-bound,multiexposure,tolerant,adaptive"


def _matte_table(report: AcceptanceReport) -> list[str]:
    """PS and SD against the predicted std, per position."""
    lines = [
        "| position | value (mm) | predicted std (mm) | phase part | calibration part "
        "| value / std | centre error (mm) |",
        "|---|---|---|---|---|---|---|",
    ]
    for o in report.outcomes:
        std = o.details.get("predicted_std_mm", {})
        parts = o.details.get("predicted_std_parts_mm", {})
        for q in ("PS", "SD"):
            v, s = o.values.get(q), std.get(q)
            if v is None or s is None:
                continue
            centre = o.details.get("error_vs_truth_mm", {}).get("centre_mm")
            c = "—" if centre is None else f"{centre:.3f}"
            ph, ca = (parts.get(k, {}).get(q) for k in ("phase", "calibration"))
            ph_text = f"{s:.4f}" if ph is None else f"{ph:.4f}"
            ca_text = "—" if ca is None else f"{ca:.4f}"
            lines.append(
                f"| {o.label} {q} | {v:+.4f} | {s:.4f} | {ph_text} | {ca_text} | {v / s:+.1f} "
                f"| {c} |"
            )
    return lines


def _hdr_table(report: AcceptanceReport) -> list[str]:
    """Per strategy: images per position, largest |PF| and |PS|, positions passed."""
    d = report.to_dict()["strategies"]
    lines = [
        "| strategy | images / position | max PF (mm) | max abs PS (mm) | PF passed | PS passed "
        "| verdict |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, s in d.items():
        q, im = s["quantities"], s["images"]
        pf, ps = q.get("PF", {}), q.get("PS", {})
        images = f"{im['per_position_min']}..{im['per_position_max']}"

        def fmt(v: float | None) -> str:
            return "—" if v is None else f"{v:.3f}"

        lines.append(
            f"| {name} | {images} | {fmt(pf.get('max_abs_mm'))} | {fmt(ps.get('max_abs_mm'))} "
            f"| {pf.get('passed')}/{pf.get('positions')} | {ps.get('passed')}/"
            f"{ps.get('positions')} | {'pass' if s['all_passed'] else 'FAIL'} |"
        )
    return lines


def blur_ablation(size: tuple[int, int], calibration: Path) -> list[str]:
    """The two positions with the largest PS and SD bias (sphere 8, ball bar 3) measured again
    without camera blur and projector defocus: how much of the bias is the optics' blur."""
    import dataclasses

    from hdrfringe.core.programs import fringe_specs
    from hdrfringe.io.stereo_file import load_stereo_calibration
    from hdrfringe.pipeline import measure
    from hdrfringe.rig.artefact_positions import (
        acceptance_positions,
        board_depth_range,
        measuring_volume,
    )
    from hdrfringe.rig.board_poses import calibration_rig, default_board_poses
    from hdrfringe.rig.scenes import white_plate
    from hdrfringe.tasks.acceptance import _artefacts, _outcome, _sidecar

    volume = measuring_volume(
        calibration_rig(white_plate(), camera_size=size),
        board_depth_range(default_board_poses(10)),
    )
    plan = acceptance_positions(volume)
    art = _artefacts(None, plan)
    cal = load_stereo_calibration(calibration)
    specs = fringe_specs("sinusoidal", 4, [1024.0, 96.0, 16.0])
    lines = [
        "| position | blur, defocus (px) | value (mm) | predicted std (mm) |",
        "|---|---|---|---|",
    ]
    for pos in (plan.spheres[7], plan.ball_bars[2]):
        for blur, defocus in ((0.5, 0.6), (0.0, 0.0)):
            rig = calibration_rig(pos.scene, camera_size=size)
            rig = rig.replace(
                camera=dataclasses.replace(rig.camera, blur_px=blur),
                projector_model=dataclasses.replace(rig.projector_model, defocus_px=defocus),
            )
            res = measure(rig, cal, specs=specs, strategy="conventional")
            o = _outcome(res, _sidecar(pos, "conventional", rig), art, cal, None)
            q = "PS" if pos.kind == "sphere" else "SD"
            v, s = o.values[q], o.details["predicted_std_mm"][q]
            lines.append(f"| {pos.label} {q} | {blur}, {defocus} | {v:+.3f} | {s:.3f} |")
    return lines


def main(argv: list[str] | None = None) -> int:
    """Run both parts and print their tables.

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
    ap.add_argument("-o", "--output", type=Path, required=True, help="folder for both runs")
    ap.add_argument("--size", default="640x480", help="camera WIDTHxHEIGHT")
    ap.add_argument("--strategies", default=STRATEGIES, help="HDR table rows, comma-separated")
    ap.add_argument("--ambient-lux", type=float, default=0.0, help="ambient light (HDR table)")
    ap.add_argument("--skip-hdr", action="store_true", help="only the matte procedure")
    ap.add_argument("--force", action="store_true")
    args = ap.parse_args(argv)
    size = parse_size(args.size)
    t0 = time.perf_counter()
    matte = acceptance_sim(args.output / "matte", size=size, force=args.force)
    wall = time.perf_counter() - t0
    print(
        f"## matte, {len(matte.outcomes)} positions at {size[0]}x{size[1]}: {wall:.0f} s wall "
        f"({json.dumps(matte.setup['seconds'])})"
    )
    print((args.output / "matte" / "acceptance.md").read_text(encoding="utf-8"))
    print("\n".join(_matte_table(matte)))
    print("\n## without blur\n")
    print("\n".join(blur_ablation(size, args.output / "matte" / "calibration.h5")))
    if args.skip_hdr:
        return 0
    t0 = time.perf_counter()
    glossy = acceptance_sim(
        args.output / "glossy",
        calibration=args.output / "matte" / "calibration.h5",
        strategies=args.strategies.split(","),
        positions="sphere",
        glossy=True,
        ambient_lux=args.ambient_lux,
        size=size,
        force=args.force,
    )
    print(f"\n## glossy sphere, HDR table ({time.perf_counter() - t0:.0f} s wall)")
    print("\n".join(_hdr_table(glossy)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
