"""The strategy and calibration contracts (issue 29, steps 2 and 3).

* ``pipeline.py`` names no strategy and reads no strategy's ``details``: its syntax tree (read
  with :mod:`ast`, nothing imported) has no import of a strategy module, no string naming a
  registered strategy or one of their parameters, no ``.details`` and no ``isinstance`` test
  of a calibration kind. The checker is first shown the lines it must reject (the ones
  pipeline.py had before the contract), so a checker that sees nothing cannot pass.
* Both calibration kinds follow :class:`~hdrfringe.core.calibration.MeasurementCalibration`, and
  ``load_any_calibration`` tells them apart by the file alone.
* The hooks: a strategy's ``prepare`` sees what the measurement offers (a replay's MIGLs, the
  projector-camera geometry) and its ``metrics`` blocks reach the metrics; a block the metrics
  do not have is refused, not dropped.
"""

from __future__ import annotations

import ast
import dataclasses
import textwrap
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.core.calibration import (
    NO_GEOMETRY,
    Calibration,
    CalibrationMismatchError,
    MeasurementCalibration,
)
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.reconstruct import CameraGeometry
from hdrfringe.core.stereo import HEIGHT_STD_NOTE, LensModel, StereoCalibration
from hdrfringe.errors import InputError
from hdrfringe.io.calibration_file import CalibrationFileError, save_calibration
from hdrfringe.io.stereo_file import load_any_calibration, save_stereo_calibration
from hdrfringe.pipeline import measure
from hdrfringe.rig.scenes import white_plate
from hdrfringe.rig.simulated import CameraModel, Lighting, SimulatedRig
from hdrfringe.strategies import (
    BUILTIN,
    MetricsContext,
    RunContext,
    StrategyMetrics,
    available_strategies,
    get_strategy,
    make_params,
    prepare_params,
    register,
    unregister,
)
from hdrfringe.strategies.lpa import LPA

PIPELINE = Path(__file__).resolve().parents[1] / "src" / "hdrfringe" / "pipeline.py"
#: Strategy modules besides the built-ins' own: their analysis, training and exposure choice.
HELPER_MODULES = ("dpa_analysis", "dpa_training", "exposure", "lpa")


def _docstrings(tree: ast.AST) -> set[int]:
    """ids of the string constants that are docstrings (module, class, function)."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                out.add(id(body[0].value))
    return out


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    """ids of every node inside an ``if TYPE_CHECKING:`` block (type-only imports)."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            for child in node.body:
                out.update(id(n) for n in ast.walk(child))
    return out


def _words() -> set[str]:
    """Registered strategy names and their Params field names (what the pipeline must not
    spell out), less the words that are the pipeline's own too: the decoder's ``min_shifts``
    and ``inverted`` (``metrics.decoder``) and the index quantity ``migl``."""
    words = set(available_strategies())
    for name in available_strategies():
        words |= {f.name for f in dataclasses.fields(get_strategy(name).Params)}
    return words - {"min_shifts", "inverted", "migl"}


def contract_breaches(source: str) -> list[str]:
    """What in ``source`` names a strategy, reads ``details`` or asks a calibration its kind."""
    tree = ast.parse(source)
    docs, typing_only, words = _docstrings(tree), _type_checking_nodes(tree), _words()
    modules = {f"hdrfringe.strategies.{m}" for m in (*BUILTIN, *HELPER_MODULES)}
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and id(node) not in typing_only:
            if node.module in modules:
                out.append(f"line {node.lineno}: imports {node.module}")
            if node.module == "hdrfringe.strategies":
                out += [
                    f"line {node.lineno}: imports strategy module {a.name}"
                    for a in node.names
                    if a.name in (*BUILTIN, *HELPER_MODULES)
                ]
        elif isinstance(node, ast.Import) and id(node) not in typing_only:
            out += [
                f"line {node.lineno}: imports {a.name}" for a in node.names if a.name in modules
            ]
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            if id(node) not in docs and node.value.lower() in words:
                out.append(f"line {node.lineno}: the string {node.value!r}")
        elif isinstance(node, ast.Attribute) and node.attr == "details":
            out.append(f"line {node.lineno}: reads .details ({ast.unparse(node)})")
        elif (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id == "isinstance"
            and len(node.args) == 2
            and {"Calibration", "StereoCalibration"}
            & {n.id for n in ast.walk(node.args[1]) if isinstance(n, ast.Name)}
        ):
            out.append(f"line {node.lineno}: {ast.unparse(node)}")
    return out


#: Lines pipeline.py had before the contract, each of which the checker must reject.
BREACHES = {
    "import": "from hdrfringe.strategies.dpa_analysis import DPACDFs, DPAMetrics, dpa_cdfs",
    "method test": 'if method == "dpa":\n    pass',
    "method attribute": 'ok = [r for r in results if r.method == "adaptive"]',
    "details key": 'phase = r.details.get("absolute_phase")',
    "details subscript": 'frames = res.details["inverted_spec"].frames()',
    "param name": 'on = getattr(p, "epipolar", False)',
    "calibration kind": "stereo = isinstance(calibration, StereoCalibration)",
    "calibration kind, either": "cal = calibration if isinstance(calibration, Calibration) else 0",
}


@pytest.mark.parametrize("what", list(BREACHES))
def test_the_checker_rejects_what_pipeline_did_before(what: str) -> None:
    assert contract_breaches(textwrap.dedent(BREACHES[what]))


def test_the_checker_allows_type_only_imports_and_docstrings() -> None:
    source = (
        '"""Measures with any strategy: dpa, lpa, adaptive."""\n'
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n"
        "    from hdrfringe.strategies.dpa_analysis import DPAMetrics\n"
    )
    assert contract_breaches(source) == []


def test_pipeline_names_no_strategy_and_asks_no_calibration_its_kind() -> None:
    assert contract_breaches(PIPELINE.read_text()) == []


# --- the calibration interface ----------------------------------------------------------------


def _stereo() -> StereoCalibration:
    cam = LensModel([[1000, 0, 40], [0, 1000, 31], [0, 0, 1]], [], (81, 62))
    proj = LensModel([[1500, 0, 456], [0, 1500, 570], [0, 0, 1]], [], (912, 1140))
    return StereoCalibration(cam, proj, np.eye(3), [-200.0, 0.0, 0.0])


def _height(geometry: dict | None = None) -> Calibration:
    return Calibration(
        "linear",
        np.full((62, 81), 0.5),
        None,
        np.zeros((62, 81)),
        np.array([2.0, 4.0]),
        border_px=0,
        spec=FringeSpec("sinusoidal", 4, 8.0),
        provenance={} if geometry is None else {"camera_geometry": geometry},
    )


def test_both_kinds_follow_the_interface_and_differ_where_they_should() -> None:
    """What each kind answers, against what the pipeline asked by isinstance before."""
    stereo, height = _stereo(), _height()
    assert isinstance(stereo, MeasurementCalibration)
    assert isinstance(height, MeasurementCalibration)
    assert (stereo.kind, stereo.output) == ("stereo", "points")
    assert (height.kind, height.output) == ("phase-to-height", "heights")
    assert stereo.projector_geometry() is stereo and height.projector_geometry() is None
    assert height.height_model() is height and stereo.height_model() is None
    assert stereo.uncertainty_notes() == (HEIGHT_STD_NOTE,) and height.uncertainty_notes() == ()
    assert height.notes() == (NO_GEOMETRY,) and stereo.notes() == ()
    geo = _height({"focal_px": 1000.0, "standoff_mm": 500.0, "cx": 40.0, "cy": 31.0})
    assert geo.notes() == () and isinstance(geo.camera_geometry(), CameraGeometry)
    assert stereo.camera_geometry() is None


def test_stereo_check_fits_names_each_size_that_differs() -> None:
    stereo = _stereo()
    stereo.check_fits(None, (62, 81), 8, projector_size=(912, 1140))
    with pytest.raises(CalibrationMismatchError) as err:
        stereo.check_fits(None, (62, 80), 8, source="s.h5", projector_size=(800, 600))
    assert str(err.value) == (
        "s.h5: stereo calibration does not fit this measurement: camera image 80x62 vs "
        "calibrated (81, 62); projector 800x600 vs calibrated (912, 1140) (W x H); use the "
        "calibration of this camera and projector"
    )


def test_load_any_calibration_knows_the_kind_from_the_file(tmp_path: Path) -> None:
    """Rejects a loader that trusts the suffix or tries one kind only: same suffix, both
    kinds, each back as what was written."""
    s = load_any_calibration(save_stereo_calibration(tmp_path / "a.h5", _stereo()))
    h = load_any_calibration(save_calibration(tmp_path / "b.h5", _height()))
    assert isinstance(s, StereoCalibration) and isinstance(h, Calibration)
    np.testing.assert_array_equal(s.translation_mm, [-200.0, 0.0, 0.0])
    np.testing.assert_array_equal(h.k_map, _height().k_map)
    (tmp_path / "c.h5").write_bytes(b"not hdf5")
    with pytest.raises(CalibrationFileError, match="not an HDF5 file"):
        load_any_calibration(tmp_path / "c.h5")


# --- the strategy hooks -----------------------------------------------------------------------


def test_prepare_hooks_take_what_the_measurement_offers() -> None:
    stereo = _stereo()
    adaptive = get_strategy("adaptive")
    on = make_params("adaptive", epipolar=True)
    assert (
        prepare_params(adaptive, on, RunContext(projector_geometry=stereo)).stereo_calibration
        is stereo
    )
    off = make_params("adaptive")
    assert prepare_params(adaptive, off, RunContext(projector_geometry=stereo)) is off
    mine = dataclasses.replace(on, stereo_calibration=_stereo())
    assert prepare_params(adaptive, mine, RunContext(projector_geometry=stereo)) is mine
    uniform = get_strategy("uniform")
    auto = make_params("uniform")
    assert prepare_params(uniform, auto, RunContext()) is auto  # live rig: any MIGL
    sweep = prepare_params(uniform, auto, RunContext(available_migls=[150.0, 200.0]))
    assert sweep.candidates == [150.0, 200.0]


class _Flagged(LPA):
    """LPA whose metrics hook fills a block by name (``block`` set per test)."""

    name = "lpa-flagged"
    block = "adaptive"

    def metrics(self, results, context):  # type: ignore[no-untyped-def]
        assert context.replay is None and context.params == make_params("lpa")
        return StrategyMetrics(metrics={self.block: {"sets": len(results)}})


def test_a_strategy_metrics_hook_fills_its_block_and_an_unknown_block_is_refused() -> None:
    rig = SimulatedRig(
        white_plate(), camera=CameraModel(width=40, height=30), lighting=Lighting(ambient_lux=600)
    )
    spec = [FringeSpec("sinusoidal", 4, 8.0)]
    register(_Flagged)
    try:
        res = measure(rig, strategy="lpa-flagged", specs=spec, uncertainty=False)
        assert res.metrics.adaptive == {"sets": 1}
        assert res.metrics.to_dict()["adaptive"] == {"sets": 1}
        _Flagged.block = "colour"
        with pytest.raises(InputError, match="'colour', not a block of MeasurementMetrics"):
            measure(rig, strategy="lpa-flagged", specs=spec, uncertainty=False)
    finally:
        _Flagged.block = "adaptive"
        unregister("lpa-flagged")
    plain = measure(rig, strategy="lpa", specs=spec, uncertainty=False)
    assert plain.metrics.adaptive is None and plain.metrics.dpa is None


def test_metrics_context_is_what_the_hook_documents() -> None:
    ctx = MetricsContext(make_params("dpa"))
    out = get_strategy("dpa").metrics([], ctx)  # type: ignore[attr-defined]
    assert out.metrics["dpa"].correction == "none (identity)" and out.result["dpa"] == ()
