"""The end-to-end demo on the virtual rig: ``hdrfringe demo``.

Two scenes, each captured, written as a capture folder, decoded as a user's folder would be,
and compared with the rig's ground truth:

* the face-like **mask** with sinusoidal 4-step fringes at pitches 1024 (one period across the
  projector), 64 and 8 px: three-frequency temporal unwrapping gives the absolute phase
  ``2*pi*x/p`` directly, and the centerline (Eq. 2.12-2.13) checks it independently;
* the black-and-white **checkerboard** at MIGL 255 with the black-plate aperture (thesis
  Sec. 5.2.2): the white squares saturate, which the saturation count and the validity mask show.
  Later stages (saturation avoidance) build on this scene.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console
from rich.table import Table

from hdrfringe.io.captures import read_capture_folder, write_capture_folder
from hdrfringe.io.phase_maps import write_phase_maps
from hdrfringe.io.results import check_output_dir, staged_output_dir
from hdrfringe.patterns import CenterlineFrame, Frame, FringeSpec
from hdrfringe.process import decode_folder
from hdrfringe.rig.scenes import BLACK_PLATE_REFLECTIVITY, checkerboard, mask
from hdrfringe.rig.simulated import SimulatedRig
from hdrfringe.unwrap import absolute_phase_from_centerline

TWO_PI = 2.0 * np.pi


def _scene_runs(seed: int) -> list[tuple[str, SimulatedRig, list[Frame], float]]:
    runs: list[tuple[str, SimulatedRig, list[Frame], float]] = []
    rig = SimulatedRig(mask(), seed=seed)
    frames: list[Frame] = []
    for p in (1024.0, 64.0, 8.0):
        frames += FringeSpec("sinusoidal", 4, p, "vertical", 40, 255).frames()
    frames.append(CenterlineFrame(512, "vertical", 255))
    runs.append(("mask", rig, frames, 8.0))
    board = SimulatedRig(checkerboard(), seed=seed)
    board = board.replace(camera=board.camera.with_aperture_for(BLACK_PLATE_REFLECTIVITY))
    frames = []
    for p in (1024.0, 64.0, 8.0):
        frames += FringeSpec("sinusoidal", 4, p, "vertical", 40, 255).frames()
    frames.append(CenterlineFrame(512, "vertical", 255))
    runs.append(("checkerboard", board, frames, 8.0))
    return runs


def _overview_figure(path: Path, panels: list[tuple[str, np.ndarray, str, str]]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(panels)
    cols = 3
    rows = (n + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.4 * rows), dpi=100)
    for ax in np.ravel(axes)[n:]:
        ax.set_axis_off()
    for ax, (title, data, cmap, unit) in zip(np.ravel(axes), panels, strict=False):
        cm = matplotlib.colormaps[cmap].with_extremes(bad="0.5")
        finite = np.isfinite(data)
        lo, hi = np.percentile(data[finite], [0.5, 99.5]) if finite.any() else (0, 1)
        im = ax.imshow(np.ma.masked_invalid(data), cmap=cm, vmin=lo, vmax=hi)
        ax.set_title(title, fontsize=9)
        ax.set_axis_off()
        fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04, label=unit)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def run_demo(
    output: Path, *, seed: int = 0, force: bool = False, console: Console | None = None
) -> dict[str, Any]:
    """Run the demo and write everything under ``output``; returns the summary.

    Output layout: ``<scene>/captures`` (a capture folder), ``<scene>/phase`` (the maps of
    ``hdrfringe phase``), ``<scene>/error_vs_truth.png``, ``overview.png`` and ``summary.json``.
    """
    console = console or Console()
    check_output_dir(output, force)
    summary: dict[str, Any] = {"seed": seed, "scenes": {}}
    panels: list[tuple[str, np.ndarray, str, str]] = []
    with staged_output_dir(output, force=force) as tmp:
        for name, rig, frames, pitch in _scene_runs(seed):
            sdir = tmp / name
            sdir.mkdir()
            images = rig.capture(frames)
            write_capture_folder(
                sdir / "captures",
                frames,
                images,
                rig.camera_bit_depth,
                projector=rig.projector,
                scene=rig.scene.to_manifest(),
                extra={"simulator": rig.to_manifest()},
            )
            caps = read_capture_folder(sdir / "captures")
            decoded = decode_folder(caps)
            (sdir / "phase").mkdir()
            write_phase_maps(sdir / "phase", decoded, str(sdir / "captures"))
            fam = decoded.primary
            assert fam is not None
            truth = rig.truth()
            true_phase = TWO_PI * truth.u / pitch
            finest = decoded.set_results[fam.sets[-1].label]
            absolute = fam.absolute_phase
            err_px = (absolute - true_phase) * pitch / TWO_PI if absolute is not None else None
            line_frame, line_img = caps.centerlines()[0]
            by_line = absolute_phase_from_centerline(
                fam.unwrapped_phase, line_img, line_frame.position, pitch, "vertical"
            )
            ok = truth.valid & np.isfinite(absolute) if absolute is not None else truth.valid
            agree = np.isfinite(by_line) & ok
            stats = {
                "captures": len(frames),
                "saturated_fraction": float(np.mean(finest.saturation_count > 0)),
                "valid_fraction": float(np.mean(np.isfinite(absolute)))
                if absolute is not None
                else 0.0,
                "phase_rms_error_rad": float(
                    np.sqrt(np.nanmean((err_px[ok] * TWO_PI / pitch) ** 2))
                )
                if err_px is not None and ok.any()
                else None,
                "projector_rms_error_px": float(np.sqrt(np.nanmean(err_px[ok] ** 2)))
                if err_px is not None and ok.any()
                else None,
                "wrong_fringe_order_fraction": float(np.mean(np.abs(err_px[ok]) > pitch / 2))
                if err_px is not None and ok.any()
                else None,
                "centerline_agrees_fraction": float(
                    np.mean(np.abs(by_line[agree] - absolute[agree]) < 1e-6)
                )
                if absolute is not None and agree.any()
                else None,
                "unwrapping": fam.method,
                "absolute": fam.absolute_method,
            }
            summary["scenes"][name] = stats
            if err_px is not None:
                e = np.where(ok, err_px, np.nan)
                _overview_figure(
                    sdir / "error_vs_truth.png",
                    [
                        ("absolute phase (rad)", absolute, "viridis", "rad"),
                        ("error vs truth (projector px)", e, "coolwarm", "px"),
                        ("saturation count", finest.saturation_count.astype(float), "inferno", ""),
                    ],
                )
            panels += [
                (
                    f"{name}: wrapped phase, pitch {pitch:g}",
                    finest.wrapped_phase,
                    "twilight",
                    "rad",
                ),
                (f"{name}: modulation I'", finest.modulation, "magma", "DN"),
                (f"{name}: saturated shifts", finest.saturation_count.astype(float), "inferno", ""),
            ]
        _overview_figure(tmp / "overview.png", panels)
        (tmp / "summary.json").write_text(json.dumps(summary, indent=1) + "\n", encoding="utf-8")

    table = Table(title="hdrfringe demo: virtual rig, sinusoidal 4-step, MIGL 255")
    for col in ("scene", "images", "saturated", "valid", "error RMS", "wrong order"):
        table.add_column(col, no_wrap=True)
    for name, st in summary["scenes"].items():
        rms = st["projector_rms_error_px"]
        wrong = st["wrong_fringe_order_fraction"]
        table.add_row(
            name,
            str(st["captures"]),
            f"{100 * st['saturated_fraction']:.1f} %",
            f"{100 * st['valid_fraction']:.1f} %",
            f"{rms:.3f} px" if rms is not None else "-",
            f"{100 * wrong:.2f} %" if wrong is not None else "-",
        )
    console.print(table)
    console.print(
        "error RMS: absolute phase against the rig's true projector coordinate, in projector "
        "pixels, over valid pixels; saturated pixels are invalid (NaN) by default."
    )
    for name, st in summary["scenes"].items():
        console.print(f"{name}: unwrapped by {st['unwrapping']}; absolute by {st['absolute']}")
    console.print(f"maps, plots and capture folders written to {output}/")
    return summary
