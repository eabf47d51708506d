"""The end-to-end demo on the virtual rig: the task of ``hdrfringe demo``.

:func:`run_demo` writes everything and returns the summary (``summary.json``);
:func:`demo_report` turns it into the tables and notes the command prints. Nothing here prints.

1. **Calibration** (thesis Sec. 2.5, 4.1): the white plate at the reference plane and the 25
   positions 2..50 mm. Both the linear model (Eq. 2.15, the thesis's) and the rational model are
   fitted; the files are written as HDF5. The checkerboard is measured with the aperture opened
   for its black squares (Sec. 5.2.2); the phase-to-height relation is geometric and does not
   depend on the aperture, so the same calibration serves (the thesis recalibrated on a black
   plate because its aperture was set on it).
2. **Measurement** with no ambient light at MIGL 255: the white plate at 10, 25 and 40 mm, the
   face-like mask, and the black-and-white checkerboard (its white squares saturate; saturated
   pixels are invalid). Sinusoidal 4-step fringes at pitches 1024, 64 and 8 px: temporal
   unwrapping from the one-period set gives the absolute phase; the centerline checks it.
3. **Saturation avoidance** (thesis Ch. 4-6): the white plate at 25 mm under 600 lx of added
   ambient light (white-plate aperture, Ch. 4) and the checkerboard (black-plate aperture,
   Sec. 5.2.2, 0 lx), each measured with the four built-in strategies
   (:data:`hdrfringe.strategies.BUILTIN`) on the live rig with the same 4-step
   1024/64/8 px family and the rational calibration: conventional (one set at MIGL 255),
   uniform (automatic: the highest MIGL at which nothing saturates, no ground truth), LPA
   (S = 5 on the plate as in Table 5.1, S = 15 on the checkerboard as in Table 5.2) and DPA
   (10 % threshold, no correction polynomial), and DPA with the pending-pixel bound (beyond the
   thesis: ``bound_pending``, fewer sets where the CDF is flat). Every strategy runs per pitch
   (:func:`hdrfringe.pipeline.measure` on the live rig); the composite is measured like any
   capture folder.
4. **Outputs**: per scene a capture folder and the files of ``hdrfringe measure`` (phase maps,
   height, PLY, metrics, ``report.html`` and ``report.md``), height previews, a 3D view of the
   mask, an overview figure and a table of RMSE per scene and model; per study scene and
   strategy the files of ``hdrfringe measure --strategy`` but the phase maps and the report
   (:func:`hdrfringe.tasks.measure.write_measurement`: height, PLY, the MIGL index
   map and pie chart, for DPA its CDF figure, Fig. 6.3, and ``metrics.json`` with
   ``sets_captured``, ``images_captured``, ``migls``, plus the study's ``params`` and
   ``rmse_mm_saturated_kept``); a figure comparing the strategies and a table of RMSE, valid
   fraction, sets and images captured (docs/saturation.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hdrfringe import pipeline
from hdrfringe.core import strict_json
from hdrfringe.core._validation import describe_saturated
from hdrfringe.core.calibration import Calibration
from hdrfringe.core.captures import ProjectorInfo
from hdrfringe.core.frames import Frame
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.programs import DEFAULT_PITCHES_PX, centerline_frame, fringe_specs
from hdrfringe.io.calibration_file import save_calibration
from hdrfringe.io.captures import write_capture_folder
from hdrfringe.io.results import check_output_dir, staged_output_dir
from hdrfringe.rig.scenes import (
    BLACK_PLATE_REFLECTIVITY,
    THESIS_CALIBRATION_DEPTHS_MM,
    Scene,
    black_plate,
    checkerboard,
    mask,
    white_plate,
)
from hdrfringe.rig.simulated import Lighting, SimulatedRig
from hdrfringe.strategies import get_strategy, make_params
from hdrfringe.tasks._progress import Progress, quiet
from hdrfringe.tasks.measure import write_measurement

__all__ = [
    "DPA_THRESHOLD",
    "PITCHES",
    "STUDY_RUNS",
    "ReportTable",
    "demo_frames",
    "demo_report",
    "demo_specs",
    "fringe_order_errors",
    "order_error_notes",
    "run_demo",
    "study_scenes",
]

PITCHES = DEFAULT_PITCHES_PX
CENTERLINE = centerline_frame(ProjectorInfo(1024, 768, 8))

STUDY_AMBIENT_LUX = 600.0  # thesis Sec. 4.2
DPA_THRESHOLD = 0.1  # thesis Ch. 6: 10 %


def study_scenes() -> list[tuple[str, str, Scene, bool, float, float]]:
    """The saturation study: (name, label, scene, black-plate aperture, ambient lux, LPA S).

    The white plate under 600 lx with the white-plate aperture (thesis Ch. 4, LPA S = 5 as in
    Table 5.1) and the checkerboard with the aperture opened for its black squares (Sec. 5.2.2,
    LPA S = 15 as in Table 5.2).

    Returns
    -------
    list of tuple
        One (name, label, scene, black-plate aperture, ambient lux, LPA S) per study scene.

    Examples
    --------
    >>> [(s[0], s[4], s[5]) for s in study_scenes()]
    [('white_plate_25mm_600lx', 600.0, 5.0), ('checkerboard', 0.0, 15.0)]
    """
    return [
        (
            "white_plate_25mm_600lx",
            f"white plate 25 mm, {STUDY_AMBIENT_LUX:g} lx",
            white_plate(25.0),
            False,
            STUDY_AMBIENT_LUX,
            5.0,
        ),
        ("checkerboard", "checkerboard, 0 lx", checkerboard(), True, 0.0, 15.0),
    ]


def demo_specs() -> list[FringeSpec]:
    """Sinusoidal 4-step at pitches 1024, 64 and 8 px (MIGL 255, imin 40), coarse first.

    Returns
    -------
    list of FringeSpec
        The demo's fringe sets (the default ladder, :data:`PITCHES`).

    Examples
    --------
    >>> [s.label() for s in demo_specs()]
    ['s4_p1024_v_i40_g255', 's4_p64_v_i40_g255', 's4_p8_v_i40_g255']
    """
    return fringe_specs("sinusoidal", 4, PITCHES, "vertical", 40, 255)


def demo_frames() -> list[Frame]:
    """The frames of :func:`demo_specs` and a centerline.

    Returns
    -------
    list of Frame
        Twelve fringe frames, then the centerline at the 1024 px projector's middle column.

    Examples
    --------
    >>> frames = demo_frames()
    >>> len(frames), frames[-1].default_name()
    (13, 'centerline_v_512_g255')
    """
    frames: list[Frame] = []
    for spec in demo_specs():
        frames += spec.frames()
    frames.append(CENTERLINE)
    return frames


def _rig(scene: Scene, seed: int, black_aperture: bool, ambient_lux: float = 0.0) -> SimulatedRig:
    rig = SimulatedRig(scene, lighting=Lighting(ambient_lux=ambient_lux), seed=seed)
    if black_aperture:
        rig = rig.replace(camera=rig.camera.with_aperture_for(BLACK_PLATE_REFLECTIVITY))
    return rig


def _calibrations(seed: int, black: bool, progress: Any) -> dict[str, Calibration]:
    plate = black_plate if black else white_plate
    frames = demo_frames()
    folders = []
    for d in (0.0, *THESIS_CALIBRATION_DEPTHS_MM):
        folders.append(_rig(plate(d), seed, black).capture_folder(frames))
        progress()
    return {m: pipeline.calibrate(folders, model=m) for m in ("linear", "rational")}


def _figure_3d(path: Path, height: np.ndarray, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    step = 4
    h = height[::step, ::step]
    rows, cols = np.indices(h.shape)
    fig = plt.figure(figsize=(8, 6), dpi=100)
    ax = fig.add_subplot(projection="3d")
    ax.plot_surface(
        cols * step,
        rows * step,
        np.ma.masked_invalid(h),
        cmap="viridis",
        linewidth=0,
        antialiased=False,
        rstride=1,
        cstride=1,
    )
    ax.set(xlabel="column (px)", ylabel="row (px)", zlabel="height (mm)", title=title)
    ax.invert_yaxis()
    ax.view_init(elev=35, azim=-60)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


Panel = tuple  # (title, data, cmap, unit) or (title, data, cmap, unit, (vmin, vmax))


def _saturated_panel(name: str, count: np.ndarray, n_sets: int) -> Panel:
    """The overview panel of a scene's saturated pixels: per pixel, the sets with a saturated
    shift, on a fixed 0..``n_sets`` range whose 0 is the palest colour (``Reds``), the title
    saying "none saturated" when no pixel is (issue 27: a range taken from the data made a
    scene with nothing saturated one solid red panel).

    Parameters
    ----------
    name : str
        The scene.
    count : ndarray of int, shape (H, W)
        Sets in which the pixel has a saturated shift.
    n_sets : int
        Sets decoded (the range's top).

    Returns
    -------
    Panel
        ``(title, data, "Reds", unit, (0, n_sets))`` for :func:`_overview`.

    Examples
    --------
    >>> _saturated_panel("plate", np.zeros((2, 2), int), 3)[0]
    'plate: saturated shifts (none saturated)'
    """
    data = np.asarray(count, dtype=np.float64)
    n = int(np.count_nonzero(data))
    state = "none saturated" if n == 0 else f"{100 * n / data.size:.1f} % of pixels"
    unit = f"sets with a saturated shift (of {n_sets})"
    return (f"{name}: saturated shifts ({state})", data, "Reds", unit, (0.0, float(n_sets)))


def _overview(path: Path, panels: list[Panel], cols: int = 3) -> None:
    """A grid of maps; NaN (invalid) in gray; each panel its own 0.5-99.5 % range or limits."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = (len(panels) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.4 * rows), dpi=100)
    for ax in np.ravel(axes)[len(panels) :]:
        ax.set_axis_off()
    for ax, (title, data, cmap, unit, *limits) in zip(np.ravel(axes), panels, strict=False):
        finite = np.isfinite(data)
        if limits:
            lo, hi = limits[0]
        else:
            lo, hi = np.percentile(data[finite], [0.5, 99.5]) if finite.any() else (0.0, 1.0)
        im = ax.imshow(
            np.ma.masked_invalid(data),
            cmap=matplotlib.colormaps[cmap].with_extremes(bad="0.5"),
            vmin=lo,
            vmax=hi,
        )
        ax.set_title(title, fontsize=9)
        ax.set_axis_off()
        fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04, label=unit)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


#: The study's runs: key (output folder, summary key) -> strategy.
STUDY_RUNS: dict[str, str] = {
    "conventional": "conventional",
    "uniform": "uniform",
    "lpa": "lpa",
    "dpa": "dpa",
    "dpa_bound": "dpa",
}


def _strategy_params(key: str, lpa_step: float) -> dict[str, Any]:
    """The study's parameters: uniform automatic (tolerance 0), LPA step S, DPA 10 % (with the
    pending-pixel bound for ``dpa_bound``)."""
    return {
        "lpa": {"step": lpa_step},
        "dpa": {"threshold": DPA_THRESHOLD},
        "dpa_bound": {"threshold": DPA_THRESHOLD, "bound_pending": True},
    }.get(key, {})


def _study_run(
    out: Path,
    scene: Scene,
    black: bool,
    lux: float,
    method: str,
    params: dict[str, Any],
    seed: int,
    cal: Calibration,
) -> tuple[dict[str, Any], np.ndarray, np.ndarray]:
    """One strategy on one scene: composite on the live rig, measured with ``cal``; writes the
    measure outputs into ``out``; returns the summary row, the height error and the finest
    pitch's MIGL index map."""
    rig = _rig(scene, seed, black, lux)
    res = pipeline.measure(
        rig, cal, strategy=method, params=params, specs=demo_specs(), centerline=CENTERLINE
    )
    results, strategy = res.strategy_results, res.metrics.strategy
    assert strategy is not None and res.height_mm is not None
    # Saturated pixels are invalid by default; the thesis (Ch. 4) measured them as they are, so
    # that saturation error counts: both figures where the composite still saturates.
    kept = res
    if (res.metrics.saturated_fraction or 0.0) > 0:
        kept = pipeline.measure(res.captures, cal, reject_saturated=False)
    row: dict[str, Any] = {
        "params": params,
        "sets_captured": strategy.sets_captured,
        "images_captured": strategy.images_captured,
        "sets_per_pitch": {f"{r.spec.pitch_px:g}": r.sets_captured for r in results},
        "migls": strategy.to_dict()["migls"],
        "never_unsaturated_fraction": strategy.never_unsaturated_fraction,  # finest pitch
        "saturated_fraction": res.metrics.saturated_fraction_measurement_pixels,
        "valid_fraction": res.metrics.valid_fraction,
        "rmse_mm": res.metrics.rmse_mm,
        "rmse_mm_saturated_kept": kept.metrics.rmse_mm,
        "valid_fraction_saturated_kept": kept.metrics.valid_fraction,
    }
    if method == "uniform":
        row["uniform_migl"] = [r.details["chosen_migl"] for r in results]
    if method == "dpa":
        rules = [rule for r in results for rule in r.details["rules"]]
        row["dpa_rules"] = {k: rules.count(k) for k in ("initial", "threshold", "lowest", "bound")}
    error = res.height_mm - rig.truth().height_mm
    row.update(fringe_order_errors(error, cal, rig.truth().reflectivity))
    extra = {
        "params": params,
        "rmse_mm_saturated_kept": row["rmse_mm_saturated_kept"],
        **{k: v for k, v in row.items() if k.startswith("order_error")},
    }
    write_measurement(res, out, extra_metrics=extra, phase_maps=False, report=False)
    return row, error, results[-1].migl_index


def fringe_order_errors(
    error_mm: np.ndarray, cal: Calibration, reflectivity: np.ndarray | None = None
) -> dict[str, Any]:
    """Pixels whose height error exceeds half a fringe of the calibrated set: fringe-order
    (unwrapping) errors, not measurement noise.

    A wrong fringe order moves a pixel's height by whole periods, ``2 pi |K|`` mm each (K the
    linear phase-to-height map, Eq. 2.15, of the finest set the calibration was made with); a
    correct order leaves the error well under half of one, ``pi |K|``.

    Parameters
    ----------
    error_mm : ndarray, shape (H, W)
        Measured minus true height (NaN = invalid).
    cal : Calibration
        The calibration of the measurement (its ``k_map`` and measurement mask).
    reflectivity : ndarray, shape (H, W), optional
        The scene's reflectivity per pixel (the virtual rig's truth): the reflectivities of the
        pixels in error are reported.

    Returns
    -------
    dict
        ``order_errors`` (pixels), ``order_error_fraction`` (of the valid measurement pixels),
        ``order_error_max_abs_mm``, ``order_error_periods`` (the distinct jumps in periods of
        the calibrated set), ``rmse_mm_without_order_errors`` and, with ``reflectivity``,
        ``order_error_reflectivity`` (distinct values, 2 decimals).

    References
    ----------
    Thesis Sec. 2.3 (unwrapping), Eq. 2.11/2.15 (height per radian), Table 4.1 (fringe-order
    failures).

    Examples
    --------
    >>> from hdrfringe.core.calibration import Calibration
    >>> cal = Calibration("linear", np.full((4, 4), 2.0), None, np.zeros((4, 4)),
    ...                   np.array([2.0, 4.0]), border_px=0)
    >>> err = np.full((4, 4), 0.1)
    >>> err[0, 0] = 4 * np.pi + 0.1  # one period of 2 pi * 2 mm/rad: a wrong order
    >>> out = fringe_order_errors(err, cal)
    >>> out["order_errors"], out["order_error_periods"]
    (1, [1])
    >>> round(out["rmse_mm_without_order_errors"], 3)
    0.1
    """
    inside = cal.measurement_mask() & np.isfinite(error_mm)
    period = 2.0 * np.pi * np.abs(cal.k_map)
    with np.errstate(invalid="ignore"):
        jumps = inside & (np.abs(error_mm) > period / 2.0)
    kept = error_mm[inside & ~jumps]
    n_valid = int(inside.sum())
    out: dict[str, Any] = {
        "order_errors": int(jumps.sum()),
        "order_error_fraction": float(jumps.sum()) / n_valid if n_valid else 0.0,
        "order_error_max_abs_mm": float(np.abs(error_mm[jumps]).max()) if jumps.any() else 0.0,
        "order_error_periods": sorted(
            {int(v) for v in np.round(error_mm[jumps] / period[jumps]).tolist()}
        ),
        "rmse_mm_without_order_errors": float(np.sqrt(np.mean(kept**2))) if kept.size else None,
    }
    if reflectivity is not None:
        out["order_error_reflectivity"] = sorted(
            {round(float(r), 2) for r in np.asarray(reflectivity)[jumps].tolist()}
        )
    return out


def _method_label(method: str, params: dict[str, Any]) -> str:
    """The strategy's own label of a run (e.g. ``"LPA S=5"``)."""
    return get_strategy(method).describe(make_params(method, **params))


StudyMaps = dict[str, dict[str, tuple[np.ndarray, np.ndarray, float]]]


def _study_figure(path: Path, maps: StudyMaps) -> None:
    """Per study scene a row of MIGL index maps (finest pitch) and a row of height errors,
    one column per method, on shared colour scales. ``maps[scene][method]`` holds the height
    error, the MIGL index map and the valid fraction."""
    panels: list[Panel] = []
    for scene, by_method in maps.items():
        lo = min(float(np.min(idx)) for _, idx, _ in by_method.values())
        errs = np.concatenate([e[np.isfinite(e)] for e, _, _ in by_method.values()])
        lim = float(np.percentile(np.abs(errs), 99.5)) if errs.size else 1.0
        for method, (_, idx, _) in by_method.items():
            title = f"{scene}\n{method}: MIGL index (8 px pitch)"
            panels.append((title, idx, "viridis", "MIGL", (lo, 255.0)))
        for method, (err, _, valid) in by_method.items():
            title = f"{scene}\n{method}: height error ({100 * valid:.1f} % valid)"
            panels.append((title, err, "coolwarm", "mm", (-lim, lim)))
    _overview(path, panels, cols=len(STUDY_RUNS))


def _saturation_study(
    tmp: Path, seed: int, cal: Calibration, progress: Any
) -> tuple[dict[str, Any], StudyMaps]:
    """Every study scene with every strategy; the summary's ``saturation_study`` scenes and
    the maps for :func:`_study_figure`."""
    study: dict[str, Any] = {}
    maps: StudyMaps = {}
    for name, label, scene, black, lux, lpa_step in study_scenes():
        rows: dict[str, Any] = {}
        maps[label] = {}
        for key, method in STUDY_RUNS.items():
            params = _strategy_params(key, lpa_step)
            out = tmp / "saturation" / name / key
            rows[key], err, idx = _study_run(out, scene, black, lux, method, params, seed, cal)
            row = rows[key]
            maps[label][_method_label(method, params)] = (err, idx, row["valid_fraction"])
            progress()
        study[name] = {
            "label": label,
            "aperture": "black plate" if black else "white plate",
            "ambient_lux": lux,
            "methods": rows,
        }
    return study, maps


def _migl_span(method: str, row: dict[str, Any]) -> str:
    """MIGLs of the finest pitch: the one used (uniform) or the highest..lowest captured."""
    if method == "uniform":
        return f"{row['uniform_migl'][-1]:g}"
    migls = row["migls"][-1] if isinstance(row["migls"][0], list) else row["migls"]
    return f"{migls[0]:g}" if len(migls) == 1 else f"{migls[0]:g}..{min(migls):g}"


@dataclass(frozen=True)
class ReportTable:
    """A table of the demo's report, as text: the front end draws it.

    Parameters
    ----------
    title : str
        The table's title.
    columns : tuple of str
        Column headers.
    rows : tuple of tuple of str
        The cells, row by row.

    Examples
    --------
    >>> ReportTable("RMSE", ("scene", "mm"), (("plate", "0.044"),)).rows[0]
    ('plate', '0.044')
    """

    title: str
    columns: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]


def _study_tables(study: dict[str, Any]) -> list[ReportTable]:
    """One table per study scene: sets, images, MIGLs, valid fraction, RMSE per strategy."""
    tables = []
    for st in study["scenes"].values():
        cols = ("strategy", "sets", "images", "MIGL 8 px", "valid", "RMSE mm", "sat. kept")
        rows = []
        for method, row in st["methods"].items():
            rows.append(
                (
                    _method_label(STUDY_RUNS[method], row["params"]),
                    str(row["sets_captured"]),
                    str(row["images_captured"]),
                    _migl_span(method, row),
                    f"{100 * row['valid_fraction']:.1f} %",
                    *(
                        "-" if v is None or not np.isfinite(v) else f"{v:.3f}"
                        for v in (row["rmse_mm"], row["rmse_mm_saturated_kept"])
                    ),
                    f"{100 * row['order_error_fraction']:.2f} %",
                )
            )
        title = f"{st['label']}, {st['aperture']} aperture, 4-step 1024/64/8 px"
        tables.append(ReportTable(title, (*cols, "order err."), tuple(rows)))
    return tables


def order_error_notes(study: dict[str, Any]) -> list[str]:
    """One sentence per study run whose RMSE is made by fringe-order errors: how many pixels,
    how large, where, and the RMSE of the rest.

    Parameters
    ----------
    study : dict
        ``summary["saturation_study"]`` of :func:`run_demo`.

    Returns
    -------
    list of str
        Empty when no run has a fringe-order error.

    Examples
    --------
    >>> row = {"params": {}, "rmse_mm": 5.2, "order_errors": 877, "order_error_fraction": 0.0029,
    ...        "order_error_max_abs_mm": 105.0, "order_error_periods": [-8, 8],
    ...        "rmse_mm_without_order_errors": 0.133, "order_error_reflectivity": [0.25],
    ...        "uniform_migl": [71.0, 71.0, 75.0]}
    >>> study = {"scenes": {"board": {"label": "checkerboard", "methods": {"uniform": row}}}}
    >>> print(order_error_notes(study)[0])  # doctest: +NORMALIZE_WHITESPACE
    checkerboard, uniform auto (MIGL 71/71/75): RMSE 5.200 mm from 877 pixels (0.29 %) with
    fringe-order errors of -8, 8 periods of the 8 px set (up to 105 mm), all of reflectivity
    0.25: at these MIGLs the darkest surfaces' modulation is too low for temporal unwrapping
    from the coarser sets; the other pixels' RMSE is 0.133 mm.
    """
    notes = []
    for st in study["scenes"].values():
        for method, row in st["methods"].items():
            if not row.get("order_errors"):
                continue
            label = _method_label(STUDY_RUNS[method], row["params"])
            migl = row.get("uniform_migl")
            where = f" (MIGL {'/'.join(f'{m:g}' for m in migl)})" if migl else ""
            refl = row.get("order_error_reflectivity")
            refl_text = f", all of reflectivity {refl[0]:g}" if refl and len(refl) == 1 else ""
            notes.append(
                f"{st['label']}, {label}{where}: RMSE {row['rmse_mm']:.3f} mm from "
                f"{row['order_errors']} pixels ({100 * row['order_error_fraction']:.2f} %) with "
                f"fringe-order errors of {', '.join(str(p) for p in row['order_error_periods'])} "
                f"periods of the {PITCHES[-1]:g} px set (up to "
                f"{row['order_error_max_abs_mm']:.0f} mm){refl_text}: at these MIGLs the "
                "darkest surfaces' modulation is too low for temporal unwrapping from the "
                "coarser sets; the other pixels' RMSE is "
                f"{row['rmse_mm_without_order_errors']:.3f} mm."
            )
    return notes


def _demo_scenes() -> list[tuple[str, Scene, bool]]:
    """The demo's scenes: name, scene, whether it is measured under the black plate's
    aperture."""
    return [
        ("white_plate_10mm", white_plate(10.0), False),
        ("white_plate_25mm", white_plate(25.0), False),
        ("white_plate_40mm", white_plate(40.0), False),
        ("mask", mask(), False),
        ("checkerboard", checkerboard(), True),
    ]


def _measure_demo_scene(
    tmp: Path,
    output: Path,
    name: str,
    scene: Scene,
    black: bool,
    seed: int,
    frames: list[Frame],
    cal_set: dict[str, Calibration],
    report: bool = True,
) -> tuple[dict[str, Any], list[Panel]]:
    """Capture one scene, write its capture folder and measurement under ``tmp / name`` (with
    ``report.html`` unless ``report`` is False); its summary entry and its overview panels
    (none for the scenes not shown)."""
    rig = _rig(scene, seed + 1, black)
    caps = rig.capture_folder(frames)
    sdir = tmp / name
    sdir.mkdir()
    write_capture_folder(sdir / "captures", caps, extra={"simulator": rig.to_manifest()})
    label = str(output / name / "captures")
    results = {m: pipeline.measure(caps, c, label=label) for m, c in cal_set.items()}
    best = results["rational"]
    # a calibrated measurement of a scene with fringes always has both
    assert best.height_mm is not None and best.decoded.primary is not None
    height, primary = best.height_mm, best.decoded.primary
    settings = {
        "input": label,
        "scene": name,
        "seed": seed + 1,
        "calibration": f"{output}/calibration_white_plate_rational.h5 (the demo's)",
    }
    write_measurement(best, sdir / "measurement", report=report, settings=settings)
    n_pixels = caps.image_shape[0] * caps.image_shape[1]  # saturated_fraction: of these
    entry = {
        "aperture": "black plate" if black else "white plate",
        "saturated_fraction": best.metrics.saturated_fraction,
        "saturated_pixels": round((best.metrics.saturated_fraction or 0.0) * n_pixels),
        "n_pixels": n_pixels,
        "valid_fraction": best.metrics.valid_fraction,
        "rmse_mm": {m: r.metrics.rmse_mm for m, r in results.items()},
        "bias_mm": {m: r.metrics.bias_mm for m, r in results.items()},
    }
    panels: list[Panel] = []
    if name in ("white_plate_25mm", "mask", "checkerboard"):
        err = height - rig.truth().height_mm
        sets = [best.decoded.set_results[s.label].saturation_count > 0 for s in primary.sets]
        panels += [
            (f"{name}: height", height, "viridis", "mm"),
            (f"{name}: error (rational)", err, "coolwarm", "mm"),
            _saturated_panel(name, np.sum(sets, axis=0), len(sets)),
        ]
    if name == "mask":
        _figure_3d(tmp / "mask_3d.png", height, "mask, measured height")
    return entry, panels


def demo_report(summary: dict[str, Any], output: Path) -> list[ReportTable | str]:
    """What ``hdrfringe demo`` prints, in order: tables and lines of text.

    Parameters
    ----------
    summary : dict
        The summary :func:`run_demo` returned (``summary.json``).
    output : Path
        The demo's output folder (named in the last line).

    Returns
    -------
    list of ReportTable or str
        The scenes table, its note, one table per study scene, the study's notes, the
        calibration residuals and where the files are.

    Examples
    --------
    >>> summary = {"scenes": {}, "saturation_study": {"scenes": {}},
    ...            "calibration_residual_mm": {"white": "0.01 mm"}}
    >>> report = demo_report(summary, Path("out"))
    >>> report[0].columns[0], report[-1]
    ('scene', 'maps, point clouds, plots and capture folders written to out/')
    """
    rows = tuple(
        (
            name,
            describe_saturated(st["saturated_pixels"], st["n_pixels"]),
            f"{100 * st['valid_fraction']:.1f} %",
            f"{st['rmse_mm']['linear']:.3f} mm",
            f"{st['rmse_mm']['rational']:.3f} mm",
        )
        for name, st in summary["scenes"].items()
    )
    report: list[ReportTable | str] = [
        ReportTable(
            "hdrfringe demo: virtual rig, 0 lx, MIGL 255, sinusoidal 4-step",
            ("scene", "saturated", "valid", "RMSE linear", "RMSE rational"),
            rows,
        ),
        "RMSE: height against the rig's ground truth over valid measurement pixels (10 px border "
        "excluded, thesis Sec. 4.1); saturated pixels are invalid by default, so the checkerboard "
        "is measured on its black squares only (the saturation-avoidance tables below recover "
        "its white squares).",
        *_study_tables(summary["saturation_study"]),
        "Saturation avoidance, rational calibration, same seed for every strategy. 'valid' and "
        "'RMSE': saturated pixels invalid (measure's default); 'sat. kept': RMSE with saturated "
        "pixels measured as they are (thesis Ch. 4). Sets and images: summed over the three "
        "pitches. uniform auto: the highest MIGL at which nothing saturates, per pitch; DPA: no "
        "correction polynomial. 'order err.': valid pixels whose height error exceeds half a "
        "fringe of the 8 px set (wrong fringe orders, not noise).",
        *order_error_notes(summary["saturation_study"]),
    ]
    report += [
        f"calibration fit residual, {a} plate: {text}"
        for a, text in summary["calibration_residual_mm"].items()
    ]
    report.append(f"maps, point clouds, plots and capture folders written to {output}/")
    return report


def run_demo(
    output: Path,
    *,
    seed: int = 0,
    force: bool = False,
    progress: Progress = quiet,
    report: bool = True,
) -> dict[str, Any]:
    """Run the demo and write everything under ``output``; return the summary (summary.json).

    The summary is strict JSON (docs/json_outputs.md): an RMSE over no valid pixel is ``None``
    (``null``), never NaN.

    Parameters
    ----------
    output : Path
        The output folder (staged: nothing partial is left when the run fails).
    seed : int
        Random seed of the virtual rig's noise.
    force : bool
        Replace an existing output folder.
    progress : Progress
        How the long stages are shown (default: not at all).
    report : bool
        Write ``report.html`` and ``report.md`` beside each scene's measurement
        (``<scene>/measurement/``, docs/report.md; the saturation study's runs have none);
        False: ``--no-report``.

    Returns
    -------
    dict
        The summary written to ``summary.json`` (:func:`demo_report` makes the printed report).

    Examples
    --------
    >>> import tempfile
    >>> out = Path(tempfile.mkdtemp())
    >>> _ = (out / "kept.txt").write_text("not replaced without force")
    >>> run_demo(out)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    hdrfringe.errors.OutputExistsError: ...
    """
    output = check_output_dir(output, force)
    frames = demo_frames()
    scenes = _demo_scenes()
    summary: dict[str, Any] = {
        "seed": seed,
        "pattern": "sinusoidal 4-step, pitches "
        + ", ".join(f"{p:g}" for p in PITCHES)
        + " px, MIGL 255, 0 lx",
        "scenes": {},
    }
    panels: list[Panel] = []
    with staged_output_dir(output, force=force) as tmp:
        with progress("calibrating (26 plate positions)", 26) as advance:
            cals = {"white": _calibrations(seed, False, advance)}
        for aperture, by_model in cals.items():
            for model, cal in by_model.items():
                save_calibration(tmp / f"calibration_{aperture}_plate_{model}.h5", cal)
        summary["calibration_residual_mm"] = {
            a: cals[a]["rational"].describe_residuals() for a in cals
        }
        with progress("measuring scenes", len(scenes)) as advance:
            for name, scene, black in scenes:
                entry, shown = _measure_demo_scene(
                    tmp, output, name, scene, black, seed, frames, cals["white"], report
                )
                summary["scenes"][name] = entry
                panels += shown
                advance()
        _overview(tmp / "overview.png", panels)
        n_study = len(study_scenes()) * len(STUDY_RUNS)
        label = f"saturation avoidance ({len(STUDY_RUNS)} runs x 2 scenes)"
        with progress(label, n_study) as advance:
            study, maps = _saturation_study(tmp, seed + 1, cals["white"]["rational"], advance)
        summary["saturation_study"] = {
            "pattern": "sinusoidal 4-step, pitches "
            + ", ".join(f"{p:g}" for p in PITCHES)
            + " px, highest MIGL 255, imin 40; every strategy runs per pitch",
            "calibration": "rational (white plate)",
            "rmse": "rmse_mm: saturated pixels invalid (measure's default); "
            "rmse_mm_saturated_kept: saturated pixels measured as they are (thesis Ch. 4)",
            "scenes": study,
        }
        _study_figure(tmp / "saturation_study.png", maps)
        summary = strict_json.plain(summary)  # what summary.json holds: a missing RMSE is None
        (tmp / "summary.json").write_text(strict_json.dumps(summary) + "\n", encoding="utf-8")
    return summary
