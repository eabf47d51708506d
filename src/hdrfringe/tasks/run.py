"""``hdrfringe run``: a project file's stages (import -> gamma -> phase -> calibrate or
calibrate-stereo -> measure) in one go, each skipped when nothing it depends on changed.

Every stage calls the task of its command (:mod:`hdrfringe.tasks.import_`, ``gamma``,
``phase``, ``calibrate``, ``calibrate_stereo``, ``measure``) with the options the project file
holds (:mod:`hdrfringe.io.project_file`) and writes into its own folder of the project's
output folder ``OUT/<stage>``. Its manifest ``OUT/manifests/<stage>.json``
(:mod:`hdrfringe.io.run_manifest`) records its key: a digest of the hdrfringe version, the
stage's options, the content hashes of its input files and the output hashes of the stages it
reads. A stage runs again when its key changed or its output is missing or changed, else it is
skipped; ``OUT/run_summary.json`` says per stage what happened and why (docs/project_file.md).
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hdrfringe.core import strict_json
from hdrfringe.errors import HdrFringeError, InputError, OutputExistsError
from hdrfringe.tasks._progress import Progress, Say, quiet, silent

__all__ = ["RunReport", "StageReport", "run_project"]

#: The run's summary file and the manifests' folder, in the project's output folder.
SUMMARY = "run_summary.json"
MANIFESTS = "manifests"
#: Where a file-writing stage puts its file inside its folder.
CALIBRATION_FILES = {"calibrate": "calibration.h5", "calibrate_stereo": "stereo.h5"}
#: Keys whose values are paths: inputs (hashed by content), not options.
_PATH_KINDS = ("file", "dir", "path", "dirs", "out")


@dataclass(frozen=True)
class StageReport:
    """What one stage of a run did.

    Parameters
    ----------
    stage : str
        Its name (the project file's table).
    status : str
        ``ran`` or ``skipped``.
    reason : str
        Why it ran (``first run``, ``options changed (harmonics)``, ``input images changed``,
        ``import output changed``, ``output metrics.json is missing``) or ``inputs unchanged``.
    output : Path
        Its folder.
    seconds : float
        Time it took (hashing included).
    notes : tuple of str
        Lines the stage's command would print (a ran stage only).

    Examples
    --------
    >>> StageReport("phase", "skipped", "inputs unchanged", Path("out/phase"), 0.01).status
    'skipped'
    """

    stage: str
    status: str
    reason: str
    output: Path
    seconds: float
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class RunReport:
    """What ``run`` did.

    Parameters
    ----------
    project : Path
        The project file.
    output : Path
        The project's output folder.
    stages : tuple of StageReport
        In the order they ran.
    summary_file : Path
        ``run_summary.json``.
    seconds : float
        The whole run.

    Examples
    --------
    >>> RunReport(Path("p.toml"), Path("out"), (), Path("out/run_summary.json"), 0.1).stages
    ()
    """

    project: Path
    output: Path
    stages: tuple[StageReport, ...]
    summary_file: Path
    seconds: float


@dataclass
class _Stage:
    """A planned stage: its inputs by key, the stages it reads, its options and its call."""

    name: str
    output: Path
    inputs: dict[str, tuple[Path, ...]]
    upstream: tuple[str, ...]
    options: dict[str, Any]
    call: Callable[[Path], list[str]]
    hashes: dict[str, list[str]] = field(default_factory=dict)


def _options(name: str, table: Mapping[str, Any]) -> dict[str, Any]:
    """A stage's options without its paths, as plain JSON values (the key's part)."""
    from hdrfringe.io.project_file import SCHEMA

    kept = {k: v for k, v in table.items() if SCHEMA[name][k].kind not in _PATH_KINDS}
    plain: dict[str, Any] = strict_json.plain(kept, nonfinite="error")
    return plain


def _import_stage(t: Mapping[str, Any]) -> Callable[[Path], list[str]]:
    def call(out: Path) -> list[str]:
        from hdrfringe.tasks.import_ import import_folder

        done = import_folder(t["images"], t["description"], out, bit_depth=t["bit_depth"],
                             crop_offset=t["crop_offset"], force=True)  # fmt: skip
        frames = done.report.manifest["frames"]
        return [f"imported {len(frames)} frames ({done.report.copied} images copied)"]

    return call


def _gamma_stage(captures: Path) -> Callable[[Path], list[str]]:
    def call(out: Path) -> list[str]:
        from hdrfringe.tasks.gamma import gamma

        lines: list[str] = []
        gamma(captures, out, force=True, say=lines.append)
        return lines

    return call


def _phase_stage(captures: Path, t: Mapping[str, Any]) -> Callable[[Path], list[str]]:
    def call(out: Path) -> list[str]:
        from hdrfringe.tasks.phase import PhaseOptions, phase

        dtype = t["map_dtype"] or ("float32" if t["saturated"] == "flag" else "float64")
        options = PhaseOptions(
            t["min_modulation"], t["keep_saturated"], t["saturated"], t["min_shifts"],
            t["previews"], t["uncertainty"], t["noise_sigma"], dtype, t["harmonics"],
            t["per_set_maps"], t["report"],
        )  # fmt: skip
        report = phase(captures, out, options, force=True)
        fams = [f"{f['orientation']} unwrapped by {f['unwrapping']}"
                for f in report.summary["families"]]  # fmt: skip
        return [f"wrote {len(report.summary['files'])} files", *fams]

    return call


def _calibrate_stage(t: Mapping[str, Any], progress: Progress) -> Callable[[Path], list[str]]:
    def call(out: Path) -> list[str]:
        from hdrfringe.tasks.calibrate import calibrate

        out.mkdir(parents=True, exist_ok=True)
        cal = calibrate(list(t["folders"]), out / CALIBRATION_FILES["calibrate"],
                        model=t["model"], window=t["window"], border=t["border"], force=True,
                        progress=progress)  # fmt: skip
        return [f"calibrated {len(cal.depths_mm)} positions; residual {cal.describe_residuals()}"]

    return call


def _stereo_stage(t: Mapping[str, Any], progress: Progress) -> Callable[[Path], list[str]]:
    def call(out: Path) -> list[str]:
        from hdrfringe.tasks.calibrate_stereo import calibrate_stereo

        out.mkdir(parents=True, exist_ok=True)
        done = calibrate_stereo(
            out / CALIBRATION_FILES["calibrate_stereo"], t["poses"] or (), board=t["board"],
            from_path=t["from"], rig=t["rig"], pose_count=t["pose_count"], noise=t["noise"],
            seed=t["seed"], window=t["window"], min_valid=t["min_valid"],
            distortion=t["distortion"], fix_intrinsics=t["fix_intrinsics"],
            camera_size=t["camera_size"], projector_size=t["projector_size"], force=True,
            progress=progress,
        )  # fmt: skip
        how = "converted" if done.converted_from is not None else "calibrated"
        return [f"{how}: baseline {done.calibration.baseline_mm:.2f} mm"]

    return call


def _measure_options(t: Mapping[str, Any], where: Path) -> Any:
    """The :class:`~hdrfringe.tasks.measure.MeasureOptions` of a ``[measure]`` table (the
    strategy's parameters checked by the registry)."""
    from hdrfringe.tasks.measure import CloudOptions, MeasureOptions

    params, min_shifts = None, t["min_shifts"]
    if t["strategy"] is not None:
        from hdrfringe.strategies import make_params

        try:
            params = make_params(t["strategy"], **t["strategy_params"])
        except InputError as exc:
            raise InputError(
                f"{where}: [measure] 'strategy_params' {exc}; fix it (docs/project_file.md)"
            ) from None
        if t["strategy"] == "tolerant":  # the strategy decodes with its own min_shifts
            min_shifts = getattr(params, "min_shifts", 3)
    return MeasureOptions(
        t["strategy"], params, {}, {}, t["stereo_directions"], t["uncertainty"],
        t["depth_range_mm"], t["keep_saturated"], t["saturated"], min_shifts, t["harmonics"],
        t["noise_sigma"], t["previews"], CloudOptions(t["mesh"], t["remove_outliers"]),
        t["report"],
    )  # fmt: skip


def _measure_stage(
    captures: Path, calibration: Path | None, options: Any
) -> Callable[[Path], list[str]]:
    def call(out: Path) -> list[str]:
        from hdrfringe.tasks.measure import measure

        result = measure(out, options, folder=captures, calibration=calibration,
                         force=True).result  # fmt: skip
        m, lines = result.metrics, []
        if m.valid_fraction is not None:
            lines.append(f"valid {100 * m.valid_fraction:.1f} % of measurement pixels")
        if m.stereo is not None:
            st = m.stereo
            line = f"triangulated {st['n_points']} points ({st['directions']})"
            if "reference_plane" in st:
                line += f", reference plane RMS {st['reference_plane']['rms_mm']:.3f} mm"
            lines.append(line)
        return lines + [f"note: {n}" for n in m.notes]

    return call


def _plan(spec: Any, out: Path, progress: Progress) -> list[_Stage]:
    """The stages of a project, in order, with their inputs, upstream stages and calls."""
    stages: list[_Stage] = []
    tables: Mapping[str, Mapping[str, Any]] = spec.tables

    def add(name: str, inputs: dict[str, Any], upstream: tuple[str, ...], call: Any) -> None:
        inputs = {k: tuple(v) if isinstance(v, tuple) else (v,) for k, v in inputs.items()}
        stages.append(_Stage(name, out / name, inputs, upstream, _options(name, tables[name]),
                             call))  # fmt: skip

    def captures(t: Mapping[str, Any]) -> tuple[Path, dict[str, Any], tuple[str, ...]]:
        if t["captures"] is not None:
            return t["captures"], {"captures": t["captures"]}, ()
        return out / "import", {}, ("import",)

    if "import" in tables:
        t = tables["import"]
        add("import", {"images": t["images"], "description": t["description"]}, (),
            _import_stage(t))  # fmt: skip
    if "gamma" in tables:
        folder, inputs, up = captures(tables["gamma"])
        add("gamma", inputs, up, _gamma_stage(folder))
    if "phase" in tables:
        folder, inputs, up = captures(tables["phase"])
        add("phase", inputs, up, _phase_stage(folder, tables["phase"]))
    if "calibrate" in tables:
        t = tables["calibrate"]
        add("calibrate", {"folders": t["folders"]}, (), _calibrate_stage(t, progress))
    if "calibrate_stereo" in tables:
        t = tables["calibrate_stereo"]
        inputs = {k: t[k] for k in ("from", "poses") if t[k] is not None}
        add("calibrate_stereo", inputs, (), _stereo_stage(t, progress))
    if "measure" in tables:
        t = tables["measure"]
        folder, inputs, up = captures(t)
        cal_stage = next((s for s in CALIBRATION_FILES if s in tables), None)
        cal = t["calibration"]
        if cal is not None:
            inputs["calibration"] = cal
        elif cal_stage is not None:
            up, cal = (*up, cal_stage), out / cal_stage / CALIBRATION_FILES[cal_stage]
        add("measure", inputs, up, _measure_stage(folder, cal, _measure_options(t, spec.source)))
    return stages


def _check_output(out: Path, stages: list[_Stage]) -> None:
    """The project's output folder: new, empty or a previous run's; outside every input."""
    from hdrfringe.io.results import check_output_against_inputs, check_writable

    if out.exists() and not out.is_dir():
        raise OutputExistsError(f"{out}: exists and is not a folder; choose another output path")
    if out.is_dir() and any(out.iterdir()) and not (out / MANIFESTS).is_dir():
        raise OutputExistsError(
            f"{out}: folder exists, is not empty and is not the output of a project run "
            f"(no {MANIFESTS}/); choose another output folder or empty it"
        )
    check_writable(out)
    check_output_against_inputs(out, [p for s in stages for v in s.inputs.values() for p in v])


def _key(stage: _Stage, upstream: Mapping[str, str], version: str) -> str:
    text = strict_json.dumps(
        {"hdrfringe": version, "stage": stage.name, "options": stage.options,
         "inputs": stage.hashes, "upstream": upstream},
        indent=None, sort_keys=True, nonfinite="error",
    )  # fmt: skip
    return hashlib.sha256(text.encode()).hexdigest()


def _why(stage: _Stage, old: Mapping[str, Any] | None, upstream: Mapping[str, str],
         version: str) -> str | None:  # fmt: skip
    """Why a stage must run (None: it need not): what differs from its manifest."""
    from hdrfringe.io.run_manifest import output_problem

    if old is None:
        return "first run"
    if old.get("hdrfringe") != version:
        return "hdrfringe version changed"
    before = old.get("options", {})
    changed = sorted(k for k in {*before, *stage.options} if before.get(k) != stage.options.get(k))
    if changed:
        return f"options changed ({', '.join(changed)})"
    for k, digests in stage.hashes.items():
        if old.get("inputs", {}).get(k) != digests:
            return f"input {k} changed"
    for k, h in upstream.items():
        if old.get("upstream", {}).get(k) != h:
            return f"{k} output changed"
    if old.get("key") != _key(stage, upstream, version):
        return "inputs changed"
    problem = output_problem(stage.output, old.get("output", {}).get("files", {}))
    return None if problem is None else f"output {problem}"


def _run_stage(
    stage: _Stage, out: Path, outputs: dict[str, str], force: bool, version: str, say: Say
) -> StageReport:
    from hdrfringe.io.run_manifest import (
        MANIFEST_FORMAT,
        digest,
        read_manifest,
        tree_files,
        write_json,
    )

    start = time.perf_counter()
    stage.hashes = {k: [digest(tree_files(p)) for p in v] for k, v in stage.inputs.items()}
    upstream = {k: outputs[k] for k in stage.upstream}
    manifest_path = out / MANIFESTS / f"{stage.name}.json"
    old = read_manifest(manifest_path)
    reason = "--force" if force else _why(stage, old, upstream, version)
    if reason is None:
        assert old is not None  # without a manifest the reason is "first run"
        outputs[stage.name] = old["output"]["sha256"]
        say(f"{stage.name}: skipped (inputs unchanged)")
        return StageReport(stage.name, "skipped", "inputs unchanged", stage.output,
                           time.perf_counter() - start)  # fmt: skip
    try:
        notes = stage.call(stage.output)
    except HdrFringeError:
        say(f"{stage.name}: failed ({reason}); the stages before it are complete")
        raise
    except KeyboardInterrupt:
        say(f"{stage.name}: interrupted; the stages before it are complete")
        raise
    files = tree_files(stage.output)
    outputs[stage.name] = digest(files)
    seconds = time.perf_counter() - start
    write_json(manifest_path, {
        **MANIFEST_FORMAT, "stage": stage.name, "key": _key(stage, upstream, version),
        "hdrfringe": version, "options": stage.options, "inputs": stage.hashes,
        "upstream": upstream, "input_paths": {k: [str(p) for p in v] for k, v in
                                              stage.inputs.items()},
        "output": {"path": stage.name, "sha256": outputs[stage.name], "files": files},
    })  # fmt: skip
    say(f"{stage.name}: ran ({reason}, {seconds:.1f} s)")
    return StageReport(stage.name, "ran", reason, stage.output, seconds, tuple(notes))


def run_project(
    project: Path,
    output: Path | None = None,
    *,
    force: bool = False,
    say: Say = silent,
    progress: Progress = quiet,
) -> RunReport:
    """Run a project file's stages, each skipped when nothing it depends on changed.

    The project file, every path it names, the output folder (new, empty or a previous run's;
    outside every input) and the strategy's parameters are checked before any stage runs, so
    a refused project writes nothing. A stage that fails leaves the stages before it complete
    (and recorded), and its own previous output as it was.

    Parameters
    ----------
    project : Path
        The project file (TOML, docs/project_file.md).
    output : Path, optional
        The project's output folder (default: the file's ``[project] output``).
    force : bool
        Run every stage again, even when nothing it depends on changed.
    say : callable
        Called with one line per stage as it finishes (``measure: ran (first run, 18.0 s)``,
        ``phase: skipped (inputs unchanged)``).
    progress : callable
        The calibration stages' long steps.

    Returns
    -------
    RunReport

    Raises
    ------
    InputError
        A bad project file (one line naming the file, the table and the key), no output
        folder, or a stage's refusal.
    OutputExistsError
        An output folder that holds something other than a previous run.

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.tasks.simulate import simulate
    >>> tmp = Path(tempfile.mkdtemp())
    >>> _ = simulate(tmp / "caps", "white_plate", rig_options={"resolution": (32, 24)},
    ...              pitches=[1024.0, 64.0])
    >>> _ = (tmp / "p.toml").write_text('[phase]\\ncaptures = "caps"\\npreviews = false\\n')
    >>> [s.status for s in run_project(tmp / "p.toml", tmp / "out").stages]
    ['ran']
    >>> [s.status for s in run_project(tmp / "p.toml", tmp / "out").stages]
    ['skipped']
    """
    from hdrfringe import __version__
    from hdrfringe.io.project_file import load_project_file
    from hdrfringe.io.run_manifest import write_json

    start = time.perf_counter()
    spec = load_project_file(project)
    out = output if output is not None else spec.output
    if out is None:
        raise InputError(
            f'{project}: no output folder; give -o OUT or [project] output = "..." '
            "(docs/project_file.md)"
        )
    stages = _plan(spec, out, progress)
    _check_output(out, stages)
    outputs: dict[str, str] = {}
    done = tuple(_run_stage(s, out, outputs, force, __version__, say) for s in stages)
    seconds = time.perf_counter() - start
    summary = {
        "format": "hdrfringe-run-summary", "version": 1, "project": str(project),
        "project_sha256": spec.sha256, "output": str(out), "seconds": round(seconds, 3),
        "stages": [
            {"stage": s.stage, "status": s.status, "reason": s.reason, "output": s.stage,
             "output_sha256": outputs[s.stage], "seconds": round(s.seconds, 3),
             "notes": list(s.notes)}
            for s in done
        ],
    }  # fmt: skip
    write_json(out / SUMMARY, summary)
    return RunReport(project, out, done, out / SUMMARY, seconds)
