"""``hdrfringe acceptance``: the VDI/VDE 2634 Part 2 acceptance test, on the virtual rig or
on captured positions (issue 25; docs/acceptance.md, "The acceptance command").

- :func:`acceptance_sim`: the whole procedure on the virtual stereo rig. The rig is calibrated
  the way a user would (:func:`hdrfringe.tasks.calibrate_stereo.calibrate_stereo` with
  ``rig="sim"``, or a given calibration file), the measuring volume and the guideline's
  positions come from the calibration's board depths
  (:func:`hdrfringe.rig.artefact_positions.acceptance_positions`), and every position is
  captured and measured by each chosen strategy (:data:`hdrfringe.tasks.compare.METHODS`
  names) through :func:`hdrfringe.pipeline.measure`; then each artefact is segmented and its
  quantities compared with the MPEs.
- :func:`acceptance_offline`: the same evaluation of capture folders written earlier (each
  carrying :data:`POSITION_FILE`, which says which artefact and position it holds; the sim
  run writes its captures that way with ``keep_captures``).

Both write, staged (all or nothing), ``acceptance.json`` (strict JSON, no NaN),
``acceptance.md``, ``quantities.png`` (PF, PS, SD, F per position against the MPE, one series
per strategy) and ``residuals/<strategy>/<position>.tiff`` (the residual map of every position,
float32, NaN off the artefact) with its PNG preview.
The tasks print nothing: the front end gives ``progress``.
"""

from __future__ import annotations

import math
import signal
import time
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from hdrfringe.core.stereo import StereoCalibration
from hdrfringe.core.strict_json import dumps, loads_strict, plain
from hdrfringe.errors import CaptureFormatError, HdrFringeError, InputError, StoppedError
from hdrfringe.io.acceptance_file import (
    load_acceptance_file,
)
from hdrfringe.tasks._acceptance_common import (
    ACCEPTANCE_JSON,
    ACCEPTANCE_MD,
    BALL_BAR_NECK_DEG,
    CALIBRATION_REPEATS,
    DEFAULT_BOARD,
    DEFAULT_PITCHES,
    DEFAULT_SIZE,
    KINDS,
    MAX_VIEW_DEG,
    POSITION_FILE,
    SIM_MPES,
    STEPS,
    Artefacts,
    _artefacts,
    _methods,
    parse_positions,
    parse_size,
)
from hdrfringe.tasks._acceptance_eval import (
    PositionOutcome,
    _evaluate,
    _point_std,
    evaluate_cloud,
)
from hdrfringe.tasks._acceptance_report import (
    AcceptanceReport,
    _fmt,
    _summaries,
    _write_report,
    acceptance_markdown,
)
from hdrfringe.tasks._progress import Progress, Say, quiet, silent

__all__ = [
    "ACCEPTANCE_JSON",
    "ACCEPTANCE_MD",
    "BALL_BAR_NECK_DEG",
    "CALIBRATION_REPEATS",
    "DEFAULT_PITCHES",
    "DEFAULT_SIZE",
    "KINDS",
    "MAX_VIEW_DEG",
    "POSITION_FILE",
    "SIM_MPES",
    "AcceptanceReport",
    "PositionOutcome",
    "acceptance_hardware",
    "acceptance_markdown",
    "acceptance_offline",
    "acceptance_sim",
    "evaluate_cloud",
    "parse_positions",
    "parse_size",
]


# --------------------------------------------------------------------------------- the sim run


def _load_stereo(path: Path, size: tuple[int, int] | None = None) -> StereoCalibration:
    """A stereo calibration file, refused when it is not one or does not fit ``size``."""
    from hdrfringe.core.calibration import CalibrationMismatchError
    from hdrfringe.io.stereo_file import load_any_calibration

    cal = load_any_calibration(path)
    if not isinstance(cal, StereoCalibration):
        raise InputError(
            f"{path}: a phase-to-height calibration; the acceptance test triangulates: give a "
            "stereo calibration (calibrate-stereo)"
        )
    if size is not None and tuple(cal.camera.size) != tuple(size):
        raise CalibrationMismatchError(
            f"{path}: stereo calibration of a {cal.camera.size[0]}x{cal.camera.size[1]} camera "
            f"does not fit --size {size[0]}x{size[1]}; give the calibration of that camera "
            "or its size"
        )
    return cal


def _sidecar(position: Any, strategy: str, rig: Any) -> dict[str, Any]:
    """What a position's capture folder records about itself: kind, index, label, the
    nominal centres (camera frame, to search near) and the virtual rig's truth."""
    rot, t = rig.geometry.world_to_camera()
    truth = position.truth.to_frame(rot, t)
    if position.kind == "sphere":
        expected = {"centre_mm": truth.centre_mm}
        camera = {"centre_mm": truth.centre_mm, "diameter_mm": truth.diameter_mm}
    elif position.kind == "ball_bar":
        expected = {"centre_a_mm": truth.centre_a_mm, "centre_b_mm": truth.centre_b_mm}
        camera = {**expected, "distance_mm": truth.distance_mm}
    else:
        expected = {"centre_mm": truth.centre_mm, "normal": truth.normal}
        camera = dict(expected)
    return plain(
        {
            "kind": position.kind,
            "index": position.index,
            "label": position.label,
            "description": position.description,
            "strategy": strategy,
            "expected": expected,
            "truth_camera": camera,
        }
    )


@dataclass(frozen=True)
class _SimSetup:
    size: tuple[int, int]
    seed: int
    noise: float
    ambient_lux: float
    pitches: tuple[float, ...]


def _measure_position(
    position: Any,
    method: Any,
    cal: StereoCalibration,
    setup: _SimSetup,
    artefacts: Artefacts,
    others: Sequence[StereoCalibration] = (),
) -> tuple[PositionOutcome, Any, dict[str, Any]]:
    """Capture and measure one position with one strategy on the virtual rig; evaluate it
    (with ``others``, the calibration's part of the PS/SD std: :func:`_calibration_term`)."""
    from hdrfringe.core.programs import fringe_specs
    from hdrfringe.pipeline import measure
    from hdrfringe.rig.board_poses import calibration_rig
    from hdrfringe.rig.simulated import Lighting

    t0 = time.perf_counter()
    rig = calibration_rig(
        position.scene, camera_size=setup.size, noise=setup.noise, seed=setup.seed
    )
    if setup.ambient_lux:
        rig = rig.replace(lighting=Lighting(ambient_lux=setup.ambient_lux))
    specs = fringe_specs("sinusoidal", STEPS, list(setup.pitches))
    res = measure(
        rig,
        cal,
        strategy=method.strategy,
        params=dict(method.params),
        specs=specs,
        label=position.label,
    )
    images = sum(r.images_captured for r in res.strategy_results)
    sidecar = _sidecar(position, method.name, rig)
    outcome = _outcome(res, sidecar, artefacts, cal, images)
    if others:
        _calibration_term(outcome, res.captures, sidecar, artefacts, others)
    outcome.seconds = time.perf_counter() - t0
    return outcome, res.captures, sidecar


def _calibration_term(
    outcome: PositionOutcome,
    captures: Any,
    sidecar: Mapping[str, Any],
    artefacts: Artefacts,
    others: Sequence[StereoCalibration],
) -> None:
    """Add the calibration's part to the outcome's predicted PS/SD std: the same captures
    triangulated with each of ``others`` (calibrations of the same rig from other noise seeds)
    and evaluated again; the sample std of the value over them and the run's own calibration
    is the calibration's std, combined with the phase noise's in quadrature."""
    from hdrfringe.pipeline import measure

    std = outcome.details.get("predicted_std_mm")
    if not std or any(v is None for v in outcome.values.values()):
        return
    (q,) = std
    values = [float(outcome.values[q] or 0.0)]
    for cal in others:
        res = measure(captures, cal, uncertainty=False)
        if res.stereo is None:
            continue
        try:
            v, _, _ = evaluate_cloud(
                res.stereo.xyz, outcome.kind, artefacts, expected=sidecar.get("expected")
            )
        except InputError:  # not found with that calibration: no value to count
            continue
        values.append(float(v[q] or 0.0))
    if len(values) < 2:
        return
    term = float(np.std(values, ddof=1))
    outcome.details["predicted_std_parts_mm"] = {
        "phase": {q: std[q]},
        "calibration": {q: term},
        "calibrations": len(values),
    }
    outcome.details["predicted_std_mm"] = {q: math.hypot(std[q], term)}


def _outcome(
    res: Any,
    sidecar: Mapping[str, Any],
    artefacts: Artefacts,
    cal: StereoCalibration,
    images: int | None,
) -> PositionOutcome:
    """Evaluate one measurement (a :class:`~hdrfringe.pipeline.MeasurementResult`)."""
    if res.stereo is None:
        raise InputError(f"{sidecar['label']}: no points triangulated; check the calibration")
    xyz = res.stereo.xyz
    unc = res.uncertainty
    pitch = None if res.decoded.primary is None else float(res.decoded.primary.pitch_px)
    std = None
    if unc is not None and unc.phase_std is not None and pitch is not None:
        std = _point_std(xyz, unc.phase_std, pitch, cal)
    values, note, details, residuals = _evaluate(xyz, sidecar, artefacts, std)
    # pixels with a clipped shift (invalid): on the artefact, the dark base never clips
    details["saturated_fraction"] = res.metrics.saturated_fraction
    return PositionOutcome(
        sidecar["strategy"],
        sidecar["label"],
        sidecar["kind"],
        sidecar["description"],
        values,
        note,
        images,
        details,
        residuals,
    )


def _calibrate(
    tmp: Path,
    size: tuple[int, int],
    board: str,
    poses: int,
    seed: int,
    noise: float,
    progress: Progress,
) -> tuple[StereoCalibration, dict[str, Any]]:
    """``calibrate-stereo --rig sim`` at the run's camera size, written into the run's folder."""
    from hdrfringe.tasks.calibrate_stereo import calibrate_stereo

    done = calibrate_stereo(
        tmp / "calibration.h5",
        rig="sim",
        board=board,
        pose_count=poses,
        seed=seed,
        noise=noise,
        camera_size=size,
        progress=progress,
    )
    return done.calibration, {
        "calibration": "calibrate-stereo --rig sim (calibration.h5)",
        "calibration_errors_vs_truth": done.errors_vs_truth,
    }


def _repeat_calibrations(
    size: tuple[int, int],
    board: str,
    poses: int,
    seeds: Sequence[int],
    noise: float,
    progress: Progress,
) -> list[StereoCalibration]:
    """``calibrate-stereo --rig sim`` again with other noise seeds (files not kept)."""
    import tempfile

    from hdrfringe.tasks.calibrate_stereo import calibrate_stereo

    out = []
    with (
        tempfile.TemporaryDirectory() as tmp,
        progress("calibration repeats", len(seeds)) as advance,
    ):
        for seed in seeds:
            done = calibrate_stereo(
                Path(tmp) / f"calibration_{seed}.h5",
                rig="sim",
                board=board,
                pose_count=poses,
                seed=seed,
                noise=noise,
                camera_size=size,
            )
            out.append(done.calibration)
            advance()
    return out


def _plan(size: tuple[int, int], glossy: bool, file: Path | None) -> tuple[Any, Artefacts]:
    """The measuring volume over the calibration's board depths, the positions, the artefacts
    (the file's calibrated sizes when given: the virtual rig then makes those artefacts)."""
    from hdrfringe.rig.artefact_positions import (
        acceptance_positions,
        board_depth_range,
        measuring_volume,
    )
    from hdrfringe.rig.board_poses import calibration_rig, default_board_poses
    from hdrfringe.rig.scenes import GLOSSY_SPECULAR, white_plate

    volume = measuring_volume(
        calibration_rig(white_plate(), camera_size=size), board_depth_range(default_board_poses(10))
    )
    sizes: dict[str, Any] = {}
    if file is not None:
        f = load_acceptance_file(file)
        if f.sphere is not None:
            sizes["sphere_diameter_mm"] = f.sphere.diameter_mm
        if f.ball_bar is not None:
            sizes["ball_distance_mm"] = f.ball_bar.distance_mm
            sizes["ball_diameter_mm"] = float(np.mean(f.ball_bar.diameters_mm))
        if f.plane is not None:
            sizes["plane_length_mm"] = f.plane.length_mm
            sizes["plane_width_mm"] = f.plane.width_mm
    plan = acceptance_positions(volume, specular=GLOSSY_SPECULAR if glossy else 0.0, **sizes)
    return plan, _artefacts(file, plan)


def _wanted(
    positions: str | None, counts: Mapping[str, int], artefacts: Artefacts
) -> list[tuple[str, int]]:
    """The positions to run: ``--positions``, or every position of the artefacts the file
    calibrates; a kind named that the file lacks is refused."""
    wanted = parse_positions(positions, counts)
    if positions is None or positions.strip() in ("", "all"):
        wanted = [(k, i) for k, i in wanted if artefacts.has(k)]
    for kind, _ in wanted:
        if not artefacts.has(kind):
            raise InputError(
                f"--positions names {kind} positions but {artefacts.source} has no "
                f"[{kind}]; add it or leave {kind} out"
            )
    if not wanted:
        raise InputError(f"no positions to run: {artefacts.source} calibrates no artefact")
    return wanted


def _chosen(plan: Any, positions: str | None, artefacts: Artefacts) -> list[Any]:
    counts = {
        "sphere": len(plan.spheres),
        "ball_bar": len(plan.ball_bars),
        "plane": len(plan.planes),
    }
    by = {(p.kind, p.index): p for p in plan.positions}
    return [by[w] for w in _wanted(positions, counts, artefacts)]


def acceptance_sim(
    output: Path,
    *,
    file: Path | None = None,
    calibration: Path | None = None,
    strategies: Sequence[str] = ("conventional",),
    positions: str | None = None,
    glossy: bool = False,
    ambient_lux: float = 0.0,
    size: tuple[int, int] = DEFAULT_SIZE,
    seed: int = 0,
    noise: float = 1.0,
    board: str = DEFAULT_BOARD,
    poses: int = 10,
    pitches: Sequence[float] = DEFAULT_PITCHES,
    keep_captures: bool = False,
    calibration_repeats: int = CALIBRATION_REPEATS,
    force: bool = False,
    progress: Progress = quiet,
) -> AcceptanceReport:
    """The acceptance test on the virtual rig: calibrate, place, capture, measure, evaluate.

    Everything given is checked (output, acceptance file, calibration, positions, strategies)
    before any work; the folder is written staged, all or nothing.

    Parameters
    ----------
    output : Path
        The result folder.
    file : Path, optional
        The acceptance file (MPEs and calibrated artefacts; the virtual artefacts are made to
        its sizes). None: the plan's guideline sizes and :data:`SIM_MPES`.
    calibration : Path, optional
        A stereo calibration of the virtual rig at ``size``; None: calibrate it
        (``calibrate-stereo --rig sim``, written as ``OUT/calibration.h5``).
    strategies : sequence of str
        :data:`~hdrfringe.tasks.compare.METHODS` names; several: the HDR table.
    positions : str, optional
        :func:`parse_positions` (None: all 23).
    glossy : bool
        Glossy artefacts (:data:`~hdrfringe.rig.scenes.GLOSSY_SPECULAR`).
    ambient_lux : float
        Ambient light on the scene.
    size : tuple of int
        Camera ``(width, height)``.
    seed : int
        Noise seed (calibration and captures).
    noise : float
        Camera read noise sigma, 8-bit gray levels.
    board : str
        The calibration board of the virtual calibration.
    poses : int
        Its board poses.
    pitches : sequence of float
        Fringe pitches, coarsest first (the coarsest spanning the projector).
    keep_captures : bool
        Also write each position's capture folder (``OUT/captures/<strategy>/<position>``,
        with :data:`POSITION_FILE`): what :func:`acceptance_offline` reads.
    calibration_repeats : int
        Without ``calibration``: calibrate this many more times (the next noise seeds) and
        add the spread of PS and SD over the calibrations to their predicted std (0: the
        phase noise's std only; a given calibration: always that).
    force : bool
        Replace an existing output folder.
    progress : callable
        The calibration and the positions, as stages.

    Returns
    -------
    AcceptanceReport

    Examples
    --------
    >>> acceptance_sim(Path("out"), positions="cube:1")
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: --positions 'cube:1': unknown artefact 'cube'; use sphere, \
ball_bar or plane, e.g. sphere:1-3,ball_bar:1,plane
    """
    from hdrfringe.io.results import check_output_against_inputs, check_output_dir

    if not (math.isfinite(ambient_lux) and ambient_lux >= 0):
        raise InputError(f"--ambient-lux {ambient_lux}: give a number of lux >= 0")
    if not (math.isfinite(noise) and noise >= 0):
        raise InputError(f"--noise {noise}: give a read noise sigma >= 0 gray levels")
    if calibration_repeats < 0:
        raise InputError(f"--calibration-repeats {calibration_repeats}: give a count >= 0")
    methods = _methods(strategies)
    parse_positions(positions, {"sphere": 10, "ball_bar": 7, "plane": 6})  # syntax, early
    check_output_against_inputs(output, [file, calibration])
    checked = check_output_dir(output, force)
    plan, artefacts = _plan(size, glossy, file)
    chosen = _chosen(plan, positions, artefacts)
    cal = None if calibration is None else _load_stereo(calibration, size)
    setup = _SimSetup(size, seed, noise, ambient_lux, tuple(float(p) for p in pitches))
    info: dict[str, Any] = {
        "rig": "sim",
        "camera": f"{size[0]}x{size[1]}",
        "artefacts": "glossy" if glossy else "matte",
        "ambient_lux": ambient_lux,
        "seed": seed,
        "read_noise_dn": noise,
        "pitches": list(setup.pitches),
        "steps": STEPS,
        "L0_mm": plan.volume.l0_mm,
        "volume_mm": [list(plan.volume.x_mm), list(plan.volume.y_mm), list(plan.volume.z_mm)],
        "plan_notes": list(plan.notes),
    }
    return _run_sim(
        checked,
        force,
        chosen,
        methods,
        cal,
        calibration,
        setup,
        artefacts,
        info,
        (board, poses),
        keep_captures,
        progress,
        calibration_repeats,
    )


def _run_sim(
    checked: Any,
    force: bool,
    chosen: Sequence[Any],
    methods: Sequence[Any],
    cal: StereoCalibration | None,
    calibration: Path | None,
    setup: _SimSetup,
    artefacts: Artefacts,
    info: dict[str, Any],
    board: tuple[str, int],
    keep: bool,
    progress: Progress,
    repeats: int = CALIBRATION_REPEATS,
) -> AcceptanceReport:
    """The staged part of :func:`acceptance_sim`."""
    from hdrfringe.io.results import staged_output_dir

    t0 = time.perf_counter()
    outcomes: list[PositionOutcome] = []
    with staged_output_dir(checked, force=force) as tmp:
        others: list[StereoCalibration] = []
        if cal is None:
            cal, cal_info = _calibrate(
                tmp, setup.size, board[0], board[1], setup.seed, setup.noise, progress
            )
            seeds = [setup.seed + 1 + k for k in range(repeats)]
            if seeds:
                others = _repeat_calibrations(
                    setup.size, board[0], board[1], seeds, setup.noise, progress
                )
                cal_info["calibration_term"] = (
                    f"predicted std of PS/SD: phase noise and the spread over {len(seeds) + 1} "
                    f"calibrations (noise seeds {setup.seed}, {', '.join(map(str, seeds))})"
                )
            else:
                cal_info["calibration_term"] = "not computed (no repeats): phase noise only"
        else:
            cal_info = {
                "calibration": str(calibration),
                "calibration_term": "not computed (a given calibration): phase noise only",
            }
        info.update(cal_info)
        t1 = time.perf_counter()
        with progress("acceptance positions", len(chosen) * len(methods)) as advance:
            for method in methods:
                for position in chosen:
                    outcome, caps, sidecar = _measure_position(
                        position, method, cal, setup, artefacts, others
                    )
                    outcomes.append(outcome)
                    if keep:
                        _keep(
                            tmp / "captures" / method.name / position.label,
                            caps,
                            {**sidecar, "images": outcome.images},
                        )
                    advance()
        info["seconds"] = {
            "calibration": round(t1 - t0, 1),
            "positions": round(time.perf_counter() - t1, 1),
        }
        report = AcceptanceReport(
            checked, outcomes, _summaries(outcomes, artefacts), artefacts, info
        )
        _write_report(tmp, report)
    return report


def _keep(folder: Path, captures: Any, sidecar: Mapping[str, Any]) -> None:
    """A position's capture folder and its sidecar."""
    from hdrfringe.io.captures import write_capture_folder

    folder.parent.mkdir(parents=True, exist_ok=True)
    write_capture_folder(folder, captures)
    (folder / POSITION_FILE).write_text(dumps(sidecar, nonfinite="error") + "\n", encoding="utf-8")


# --------------------------------------------------------------------------------- offline


def read_sidecar(folder: Path) -> dict[str, Any]:
    """A position folder's :data:`POSITION_FILE`, checked.

    Parameters
    ----------
    folder : Path
        A capture folder of one position.

    Returns
    -------
    dict
        ``kind``, ``label``, ``description``, ``strategy`` and, when known, ``expected``
        (nominal centres, camera frame) and ``truth_camera``.

    Raises
    ------
    CaptureFormatError
        No sidecar, not JSON, a kind or label missing or unknown.

    Examples
    --------
    >>> read_sidecar(Path("no-such-folder"))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    hdrfringe.errors.CaptureFormatError: no-such-folder: no acceptance_position.json; ...
    """
    path = Path(folder) / POSITION_FILE
    fix = (
        'write {"kind": "sphere", "label": "sphere_01"} (kind sphere, ball_bar or plane) '
        "beside the manifest"
    )
    if not path.is_file():
        raise CaptureFormatError(f"{folder}: no {POSITION_FILE}; {fix}")
    try:
        data = loads_strict(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as err:
        raise CaptureFormatError(f"{path}: not readable JSON ({err}); {fix}") from None
    if not isinstance(data, dict) or data.get("kind") not in KINDS:
        raise CaptureFormatError(f"{path}: 'kind' must be sphere, ball_bar or plane; {fix}")
    if not isinstance(data.get("label"), str) or not data["label"]:
        raise CaptureFormatError(f"{path}: 'label' must be a non-empty string; {fix}")
    data.setdefault("description", "")
    data.setdefault("strategy", "captured")
    return data


def acceptance_offline(
    folders: Sequence[Path],
    output: Path,
    *,
    calibration: Path,
    file: Path,
    force: bool = False,
    progress: Progress = quiet,
) -> AcceptanceReport:
    """Evaluate captured positions: each folder a capture folder with :data:`POSITION_FILE`.

    Every folder's sidecar, the calibration (a stereo calibration that fits the captures) and
    the acceptance file are checked before any measurement; the output is written staged.

    Parameters
    ----------
    folders : sequence of Path
        The position folders.
    output : Path
        The result folder.
    calibration : Path
        The stereo calibration.
    file : Path
        The acceptance file.
    force : bool
        Replace an existing output folder.
    progress : callable
        The positions, as one stage.

    Returns
    -------
    AcceptanceReport

    Examples
    --------
    >>> acceptance_offline([], Path("out"), calibration=Path("c.h5"), file=Path("a.toml"))
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: no position folders given; give the capture folders of the \
positions (acceptance FOLDER... --calibration CAL --file acceptance.toml -o OUT)
    """
    from hdrfringe.io.captures import DECODE_BYTES_PER_PIXEL, read_capture_folder
    from hdrfringe.io.results import (
        check_output_against_inputs,
        check_output_dir,
        staged_output_dir,
    )
    from hdrfringe.pipeline import measure

    if not folders:
        raise InputError(
            "no position folders given; give the capture folders of the positions "
            "(acceptance FOLDER... --calibration CAL --file acceptance.toml -o OUT)"
        )
    sidecars = [read_sidecar(f) for f in folders]
    seen: dict[tuple[str, str], Path] = {}
    for f, s in zip(folders, sidecars, strict=True):
        key = (s["strategy"], s["label"])
        if key in seen:
            raise InputError(
                f"{f}: position {s['label']} ({s['strategy']}) is also {seen[key]}; "
                "give each position once"
            )
        seen[key] = f
    check_output_against_inputs(output, [*folders, calibration, file])
    checked = check_output_dir(output, force)
    artefacts = _artefacts(file, None)
    for s in sidecars:
        if not artefacts.has(s["kind"]):
            raise InputError(f"{file} has no [{s['kind']}] for position {s['label']}; add it")
    cal = _load_stereo(calibration)
    outcomes = []
    with progress("acceptance positions", len(folders)) as advance:
        for f, s in zip(folders, sidecars, strict=True):
            t0 = time.perf_counter()
            caps = read_capture_folder(f, work_bytes_per_pixel=DECODE_BYTES_PER_PIXEL)
            res = measure(caps, cal, label=str(f), calibration_source=str(calibration))
            outcome = _outcome(res, s, artefacts, cal, len(caps.frames))
            outcome.images = s.get("images", outcome.images)
            outcome.seconds = time.perf_counter() - t0
            outcomes.append(outcome)
            advance()
    outcomes.sort(key=lambda o: (o.strategy, KINDS.index(o.kind), o.label))
    info = {"rig": "captured positions", "calibration": str(calibration), "positions": len(folders)}
    report = AcceptanceReport(checked, outcomes, _summaries(outcomes, artefacts), artefacts, info)
    with staged_output_dir(checked, force=force) as tmp:
        _write_report(tmp, report)
    return report


# --------------------------------------------------------------------------------- live


#: The guideline's positions per artefact (the virtual rig's plan has the same counts).
GUIDELINE_COUNTS = {"sphere": 10, "ball_bar": 7, "plane": 6}


def _acceptance_rig(rig_config: Path | None, given: Collection[str], **options: Any) -> Any:
    """The (not yet open) hardware rig and its resolved configuration: the one place this
    task builds it (:func:`~hdrfringe.tasks.capture.hardware_rig`)."""
    from hdrfringe.tasks.capture import hardware_rig

    return hardware_rig(rig_config, given, **options)


@dataclass
class _Live:
    """A live run's state: the positions written, and why it stopped early."""

    outcomes: list[PositionOutcome] = field(default_factory=list)
    stopped: str | None = None
    code: int = 0
    failure: HdrFringeError | None = None
    dropped: bool = True


def acceptance_hardware(
    output: Path,
    rig_config: Path | None,
    hardware: Mapping[str, Any],
    *,
    wait: Callable[[int, int, str], bool],
    calibration: Path | None,
    file: Path | None,
    given: Collection[str] = (),
    strategy: str = "conventional",
    positions: str | None = None,
    force: bool = False,
    say: Say = silent,
) -> AcceptanceReport:
    """The acceptance test on a hardware rig: the user places the artefact at each position.

    Before each position ``wait(number, total, label)`` returns once the artefact is in place
    (False finishes); the strategy captures vertical fringe sets (pitches as ``capture-poses``
    takes them, :func:`~hdrfringe.tasks.capture_poses.board_pitches`), the position's capture
    folder is written with :data:`POSITION_FILE` under ``OUT/captures/STRATEGY/POSITION`` and
    evaluated (no nominal centres: the artefact is searched in the whole cloud). Ctrl-C,
    SIGTERM, SIGHUP or an error mid-run keeps the complete positions (their report written)
    and raises :class:`~hdrfringe.errors.StoppedError`; before the first position nothing is
    written.

    Parameters
    ----------
    output : Path
        The result folder.
    rig_config : Path or None
        The rig configuration file.
    hardware : mapping
        Hardware options by Python name (:data:`~hdrfringe.tasks.capture.RIG_OPTION_KEYS`).
    wait : callable
        ``wait(number, total, label)``.
    calibration : Path
        The stereo calibration of this camera and projector (required).
    file : Path
        The acceptance file (required).
    given : collection of str
        The hardware options given explicitly.
    strategy : str
        One :data:`~hdrfringe.tasks.compare.METHODS` name.
    positions : str, optional
        :func:`parse_positions` over the guideline's 10/7/6 (default: every position of the
        artefacts the file calibrates).
    force : bool
        Replace an existing output folder.
    say : callable
        Called with the line saying the rig is open and one line per position.

    Returns
    -------
    AcceptanceReport

    Examples
    --------
    >>> acceptance_hardware(Path("out"), None, {}, wait=lambda n, t, s: True,
    ...                     calibration=None, file=None)
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: --rig hardware needs --calibration CAL and --file acceptance.toml
    """
    from hdrfringe.io.results import check_output_against_inputs, check_output_dir

    if calibration is None or file is None:
        raise InputError("--rig hardware needs --calibration CAL and --file acceptance.toml")
    (method,) = _methods([strategy])
    artefacts = _artefacts(file, None)
    wanted = _wanted(positions, GUIDELINE_COUNTS, artefacts)
    cal = _load_stereo(calibration)
    rig, config = _acceptance_rig(rig_config, given, **hardware)
    check_output_against_inputs(output, [rig_config, config.gamma_file, calibration, file])
    checked = check_output_dir(output, force)
    info = {"rig": "hardware", "calibration": str(calibration), "strategy": method.name}
    return _run_live(checked, force, (rig, config, cal), method, wanted, artefacts, wait, say, info)


def _run_live(
    checked: Any,
    force: bool,
    devices: tuple[Any, Any, StereoCalibration],
    method: Any,
    wanted: Sequence[tuple[str, int]],
    artefacts: Artefacts,
    wait: Callable[[int, int, str], bool],
    say: Say,
    info: dict[str, Any],
) -> AcceptanceReport:
    """The staged part of :func:`acceptance_hardware`."""
    from hdrfringe.core.programs import fringe_specs
    from hdrfringe.io.results import staged_output_dir
    from hdrfringe.tasks.capture import announce_line
    from hdrfringe.tasks.capture_poses import board_pitches

    live = _Live()
    rig, config, _ = devices
    with rig, staged_output_dir(checked, force=force) as tmp:
        pitches = board_pitches(rig.projector.width, rig.projector.height)
        specs = fringe_specs("sinusoidal", STEPS, list(pitches))
        say(announce_line(method.strategy, rig, config))
        for number, (kind, index) in enumerate(wanted, 1):
            label = f"{kind}_{index:02d}"
            sidecar = {
                "kind": kind,
                "index": index,
                "label": label,
                "description": "",
                "strategy": method.name,
            }
            if not _live_step(
                live,
                number,
                len(wanted),
                sidecar,
                wait,
                devices,
                method,
                specs,
                artefacts,
                tmp,
                say,
            ):
                break
        if not live.outcomes:
            raise HdrFringeError(
                f"acceptance {live.stopped or 'stopped'} before the first position; nothing written"
            )
        info.update(pitches=list(pitches), positions=len(live.outcomes))
        info["complete"] = len(live.outcomes) == len(wanted)
        if live.stopped:
            info["stopped"] = live.stopped
        report = AcceptanceReport(
            checked, live.outcomes, _summaries(live.outcomes, artefacts), artefacts, info
        )
        _write_report(tmp, report)
    _raise_if_stopped(live, checked)
    return report


def _live_step(
    live: _Live,
    number: int,
    total: int,
    sidecar: dict[str, Any],
    wait: Callable[[int, int, str], bool],
    devices: tuple[Any, Any, StereoCalibration],
    method: Any,
    specs: Sequence[Any],
    artefacts: Artefacts,
    tmp: Path,
    say: Say,
) -> bool:
    """One position live; False when the run ends (q, a stop, an error after a position)."""
    from hdrfringe.hardware.rig import Recorder
    from hdrfringe.io.results import SignalStop, deferred_signals, signals_as_interrupt
    from hdrfringe.pipeline import measure
    from hdrfringe.tasks.capture import live_record, stop_reason, write_capture_output

    rig, config, cal = devices
    label = sidecar["label"]
    try:
        with signals_as_interrupt():
            if not wait(number, total, label):
                live.stopped = "finished with q"
                return False
            rig.rebaseline()  # the artefact moved: a new reference image of the screen
            start = len(rig.log)
            recorder = Recorder(rig)
            res = measure(
                recorder,
                cal,
                strategy=method.strategy,
                params=dict(method.params),
                specs=specs,
                label=label,
            )
            images = sum(r.images_captured for r in res.strategy_results)
            outcome = _outcome(res, sidecar, artefacts, cal, images)
            with deferred_signals(honour=False) as held:
                caps, state, log = live_record(
                    recorder,
                    rig,
                    config,
                    method.strategy,
                    label,
                    entries={"acceptance_position": label},
                    start=start,
                )
                folder = tmp / "captures" / method.name / label
                folder.mkdir(parents=True)
                write_capture_output(folder, caps, state, log)
                text = dumps({**sidecar, "images": images}, nonfinite="error")
                (folder / POSITION_FILE).write_text(text + "\n", encoding="utf-8")
                live.outcomes.append(outcome)
            say(
                f"{label}: {images} images, "
                + ", ".join(f"{k} {_fmt(v)} mm" for k, v in outcome.values.items())
                + (f" ({outcome.note})" if outcome.note else "")
            )
            if held() == signal.SIGINT:
                raise KeyboardInterrupt
            if held() is not None:
                raise SignalStop(int(held() or 0))
    except KeyboardInterrupt as stop:
        if not live.outcomes:
            raise
        live.stopped, live.code = stop_reason(stop)
        live.dropped = live.outcomes[-1].label != label
        return False
    except HdrFringeError as err:
        if not live.outcomes:
            raise
        live.stopped, live.failure = f"stopped by an error at {label}", err
        return False
    return True


def _raise_if_stopped(live: _Live, output: Path) -> None:
    """A run stopped by a signal or an error: its complete positions are written; say so."""
    if live.failure is None and not live.code:
        return
    what = (
        f"{len(live.outcomes)} complete positions ({live.outcomes[0].label} .. "
        f"{live.outcomes[-1].label})"
    )
    why = (
        live.stopped
        if live.failure is None
        else (f"{live.stopped}: {' '.join(str(live.failure).split())}")
    )
    raise StoppedError(
        f"acceptance {why}; {output} holds the {what} evaluated before it"
        + (", the position being captured was dropped" if live.dropped else ""),
        live.code or 2,
    )
