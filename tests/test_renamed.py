"""One name per concept (issue 29): "strategy" is what users see, the old "method" spellings
still work, deprecated; the per-pixel MIGL maps are typed fields of the strategy result.

* The library: ``measure(method=...)``, ``composite_captures``/``run_at_exposure``/``compare``'s
  old keywords and the dataclass fields (``StrategyResult.method``, ``StrategySummary.method``,
  ``MeasureOptions(method=...)``, ``CompareReport.methods``) give what the new names give, each
  with a :class:`DeprecationWarning` naming the new spelling; both spellings with different
  values are refused.
* The command line: ``--method`` and ``compare --methods`` are accepted, hidden from
  ``--help``, with one deprecation line on stderr; given with a different ``--strategy`` the
  command is refused in one line (exit 2).
* ``measure`` writes ``projector_migl_map.tiff`` / ``camera_migl.tiff`` from the typed fields of
  :class:`~hdrfringe.strategies.StrategyResult`, never from ``details`` by key.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import tifffile

from hdrfringe import pipeline
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import InputError
from hdrfringe.rig.scenes import white_plate
from hdrfringe.rig.simulated import CameraModel, Lighting, SimulatedRig
from hdrfringe.strategies.base import CapturedSet, StrategyResult
from hdrfringe.strategies.exposure import run_at_exposure
from hdrfringe.tasks.compare import CompareReport
from hdrfringe.tasks.measure import MeasureOptions, write_migl_maps
from tests.conftest import run_cli_in_process

SPEC = FringeSpec("sinusoidal", 4, 8.0)


def _rig() -> SimulatedRig:
    return SimulatedRig(
        white_plate(), camera=CameraModel(width=48, height=36), lighting=Lighting(ambient_lux=600)
    )


def _deprecated(call, new: str):  # type: ignore[no-untyped-def]
    """``call()`` under a recording filter: its value, after checking it warned once about
    ``new``."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        value = call()
    messages = [str(w.message) for w in caught if issubclass(w.category, DeprecationWarning)]
    assert len(messages) == 1 and new in messages[0], messages
    return value


def _result(**fields):  # type: ignore[no-untyped-def]
    base = {
        "images": np.zeros((4, 2, 3), np.uint8), "spec": SPEC, "captured": [CapturedSet(255.0)],
        "index_map": np.full((2, 3), 255.0, np.float32), "newly_unsaturated": [6],
        "never_unsaturated": np.zeros((2, 3), bool),
    }  # fmt: skip
    return StrategyResult(**base, **fields)


# --- the library -------------------------------------------------------------------------------


def test_measure_takes_the_old_keyword_with_a_warning_and_measures_the_same() -> None:
    """Rejects an alias that is dropped (TypeError), silent, or routed elsewhere (other MIGLs)."""
    new = pipeline.measure(_rig(), strategy="lpa", params={"step": 20.0}, specs=[SPEC])
    old = _deprecated(
        lambda: pipeline.measure(_rig(), method="lpa", params={"step": 20.0}, specs=[SPEC]),
        "use strategy=",
    )
    assert old.metrics.strategy is not None and new.metrics.strategy is not None
    assert old.metrics.strategy.name == new.metrics.strategy.name == "lpa"
    assert old.metrics.strategy.values == new.metrics.strategy.values
    assert len(new.metrics.strategy.values) > 2  # LPA stepped down: not the default strategy
    assert np.array_equal(old.captures.images, new.captures.images)
    assert old.metrics.to_dict() == new.metrics.to_dict()
    assert new.metrics.to_dict()["method"] == "lpa"  # the metrics.json key is unchanged


def test_the_two_spellings_with_different_values_are_refused() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        with pytest.raises(InputError, match="strategy='lpa' and the deprecated method='dpa'"):
            pipeline.measure(_rig(), strategy="lpa", method="dpa", specs=[SPEC])


def test_composite_captures_and_run_at_exposure_take_the_old_keyword() -> None:
    caps, (res,) = _deprecated(
        lambda: pipeline.composite_captures(_rig(), [SPEC], method="conventional"),
        "use strategy=",
    )
    assert res.strategy == "conventional" and len(caps.frames) == 4
    _, res, _ = _deprecated(lambda: run_at_exposure(_rig(), SPEC, method="uniform"), "strategy=")
    assert res.strategy == "uniform"
    with pytest.raises(InputError, match="needs a strategy"):
        pipeline.composite_captures(_rig(), [SPEC])


def test_renamed_fields_read_and_construct_under_their_old_names() -> None:
    res = _deprecated(lambda: _result(method="lpa"), "use strategy=")
    assert res.strategy == "lpa"
    assert _deprecated(lambda: res.method, "read .strategy") == "lpa"
    summary = pipeline.strategy_summary([res])
    assert summary.name == "lpa" and summary.to_dict()["method"] == "lpa"
    assert _deprecated(lambda: summary.method, "read .name") == "lpa"
    options = _deprecated(lambda: MeasureOptions(method="dpa"), "use strategy=")
    assert options.strategy == "dpa" and options.pipeline_kwargs(None)["strategy"] == "dpa"
    report = CompareReport(Path("out"), [], ["glossy"], ["lpa-1"], [])
    assert _deprecated(lambda: report.methods, "read .strategies") == ["lpa-1"]


# --- the command line --------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("command", "new", "old"), [("measure", "--strategy", "--method"),
                                ("capture", "--strategy", "--method"),
                                ("compare", "--strategies", "--methods")],
)  # fmt: skip
def test_the_old_options_are_hidden_from_help(command: str, new: str, old: str) -> None:
    res = run_cli_in_process(command, "--help")
    assert res.returncode == 0, res.stderr
    words = res.stdout.replace("│", " ").split()
    assert new in words and old not in words


def _errors(res) -> list[str]:  # type: ignore[no-untyped-def]
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    return [ln.strip() for ln in res.stderr.splitlines() if ln.strip()]


def test_the_old_option_reaches_the_strategy_with_one_note(tmp_path: Path) -> None:
    """``--method magic`` is refused as ``--strategy magic`` is: the value went to the strategy
    (an ignored alias would measure conventionally and exit 0)."""
    new = _errors(run_cli_in_process("measure", "--rig", "sim", "--strategy", "magic",
                                     "-o", str(tmp_path / "a")))  # fmt: skip
    old = _errors(run_cli_in_process("measure", "--rig", "sim", "--method", "magic",
                                     "-o", str(tmp_path / "b")))  # fmt: skip
    assert old == ["note: --method is deprecated; use --strategy", *new]
    assert len(new) == 1 and "unknown strategy 'magic'" in new[0]
    cmp = _errors(run_cli_in_process("compare", "--methods", "lpa-2", "-o", str(tmp_path / "c")))
    assert cmp[0] == "note: --methods is deprecated; use --strategies"
    assert len(cmp) == 2 and "--strategies: unknown name 'lpa-2'" in cmp[1]


def test_the_old_and_the_new_option_disagreeing_are_refused(tmp_path: Path) -> None:
    res = run_cli_in_process("measure", "--rig", "sim", "--strategy", "lpa", "--method", "dpa",
                             "-o", str(tmp_path / "out"))  # fmt: skip
    lines = _errors(res)
    assert len(lines) == 2 and "--strategy lpa and the deprecated --method dpa disagree" in lines[1]
    assert not (tmp_path / "out").exists()


# --- the per-pixel MIGL maps: typed fields -----------------------------------------------------


def test_the_migl_maps_are_written_from_the_typed_fields(tmp_path: Path) -> None:
    """A result carrying the maps only in ``details`` (the old by-key read) writes nothing; the
    typed fields are written as they are."""
    pmap = np.arange(12, dtype=np.float32).reshape(3, 4)
    cam = np.full((2, 3), 100.0, np.float32)
    keyed = _result(strategy="x", details={"projector_migl_map": pmap, "camera_migl": cam})
    assert write_migl_maps(tmp_path / "a", [keyed], previews=False) == []
    typed = _result(strategy="x", projector_migl_map=pmap, camera_migl=cam)
    (tmp_path / "b").mkdir()
    files = write_migl_maps(tmp_path / "b", [typed], previews=False)
    assert files == ["projector_migl_map.tiff", "camera_migl.tiff"]
    assert np.array_equal(tifffile.imread(tmp_path / "b" / files[0]), pmap)
    assert np.array_equal(tifffile.imread(tmp_path / "b" / files[1]), cam)


def test_the_measure_task_reads_no_strategy_details() -> None:
    """tasks/measure.py names what it writes by typed fields: no ``.details`` anywhere in it
    (the maps were read as ``r.details["projector_migl_map"]``; such a line fails this)."""
    import ast

    import hdrfringe.tasks.measure as task

    def reads(source: str) -> list[str]:
        nodes = ast.walk(ast.parse(source))
        return [ast.unparse(n) for n in nodes if getattr(n, "attr", None) == "details"]

    assert reads(Path(task.__file__).read_text(encoding="utf-8")) == []
    assert reads('adapted = [r for r in results if "projector_migl_map" in r.details]')
