"""Strict JSON in every file the product writes (issue 27): no bare NaN or Infinity.

The helper (:mod:`hdrfringe.core.strict_json`) against :func:`json.dumps` itself (finite
documents: the same bytes) and against a parser that refuses the bare constants; then each
results writer on a tiny input carrying non-finite numbers: they are ``null``, never ``NaN``.
The demo's files are checked in ``tests/test_demo_and_simulate.py`` (its own run).
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.core.captures import Captures
from hdrfringe.core.strict_json import dumps, loads_strict, plain

NAN, INF = float("nan"), float("inf")


def test_finite_documents_are_written_exactly_as_json_dumps_writes_them() -> None:
    """Rejects a helper that rounds or reformats floats (``:.6g``), writes ints as floats,
    or drops -0.0, tiny or huge values: the reference is the standard library's own text."""
    rng = np.random.default_rng(3)
    values = [*rng.normal(0.0, 1e3, 20).tolist(), 0.1, -0.0, 5e-324, 1.7976931348623157e308]
    doc = {"f": values, "i": [0, -7, 2**53 + 1], "b": [True, False], "n": None,
           "t": (1.5, "x"), "nest": {"a": {"b": [0.25, {"c": 3}]}}, "s": "é\n"}  # fmt: skip
    for indent in (None, 1, 2):
        assert dumps(doc, indent=indent) == json.dumps(doc, indent=indent)
    # numpy scalars and arrays write as the Python numbers and lists they hold
    arrays = {"f": np.asarray(values), "i": np.asarray([0, -7, 2**53 + 1], np.int64),
              "b": np.asarray([True, False]), "n": None, "t": (np.float64(1.5), "x"),
              "nest": {"a": {"b": [np.float64(0.25), {"c": np.int32(3)}]}}, "s": "é\n"}  # fmt: skip
    assert dumps(arrays) == json.dumps(doc, indent=1)
    assert type(plain(np.int64(3))) is int and type(plain(np.float32(0.5))) is float


@pytest.mark.parametrize("bad", [NAN, INF, -INF, np.float32("nan"), np.float64("-inf")])
def test_non_finite_numbers_are_null_or_refused(bad: float) -> None:
    doc = {"rmse_mm": bad, "rows": [{"x": [1.0, bad]}], "a": np.array([bad, 2.0])}
    text = dumps(doc)
    assert "NaN" not in text and "Infinity" not in text
    assert loads_strict(text) == {"rmse_mm": None, "rows": [{"x": [1.0, None]}], "a": [None, 2.0]}
    with pytest.raises(ValueError, match=r"rows\[0\]\.x\[1\] is (nan|inf|-inf)"):
        dumps({"ok": 1.0, "rows": [{"x": [1.0, bad]}]}, nonfinite="error")
    with pytest.raises(TypeError, match="set is not JSON-serialisable"):
        dumps({"what": {1, 2}})


@pytest.mark.parametrize("constant", ["NaN", "Infinity", "-Infinity"])
def test_the_strict_parser_refuses_what_json_dumps_writes_by_default(constant: str) -> None:
    """The test's parser is able to fail: it refuses what ``json.dumps`` writes for NaN."""
    text = json.dumps({"v": float(constant.replace("Infinity", "inf"))})
    assert constant in text
    with pytest.raises(ValueError, match=f"bare {constant}"):
        loads_strict(text)
    assert math.isnan(json.loads('{"v": NaN}')["v"])  # what a lax parser would accept


def _captures() -> Captures:
    """The 64x48 three-pitch folder of tests/test_phase_outputs.py."""
    from tests.test_phase_outputs import _captures as small

    return small()


def test_measure_and_phase_summaries_write_null(tmp_path: Path) -> None:
    """metrics.json (the extra metrics the demo adds: an RMSE over no pixel) and
    phase_summary.json (a harmonics block with a failed estimate) hold null, not NaN."""
    from hdrfringe.core.decode import decode_captures
    from hdrfringe.io.phase_maps import write_phase_maps
    from hdrfringe.pipeline import measure
    from hdrfringe.tasks.measure import write_measurement

    result = measure(_captures())
    write_measurement(
        result, tmp_path / "m", extra_metrics={"rmse_mm_saturated_kept": NAN, "x": [INF]},
        previews=False,
    )  # fmt: skip
    metrics = loads_strict((tmp_path / "m" / "metrics.json").read_text())
    assert metrics["rmse_mm_saturated_kept"] is None and metrics["x"] == [None]
    loads_strict((tmp_path / "m" / "phase_summary.json").read_text())
    decoded = dataclasses.replace(
        decode_captures(_captures()), harmonics={"mode": "auto", "rms_rad": NAN}
    )
    (tmp_path / "p").mkdir()
    write_phase_maps(tmp_path / "p", decoded, "memory", previews=False)
    summary = loads_strict((tmp_path / "p" / "phase_summary.json").read_text())
    assert summary["harmonics"] == {"mode": "auto", "rms_rad": None}


def test_gamma_and_capture_log_write_null(tmp_path: Path) -> None:
    from hdrfringe.core.frames import UniformFrame
    from hdrfringe.core.gamma.report import gamma_report
    from hdrfringe.io.gamma_outputs import write_gamma_outputs
    from hdrfringe.tasks.capture import write_capture_output

    levels = [0, 64, 128, 192, 255]
    images = np.stack([np.full((4, 4), 10 + 200 * (g / 255) ** 2.2) for g in levels])
    caps = Captures([UniformFrame(g) for g in levels], np.rint(images).astype(np.uint8), 8)
    report = gamma_report(caps, source="x")
    report.report["probe"] = {"stderr": NAN}
    out = write_gamma_outputs(tmp_path / "g", report)
    written = loads_strict((out / "gamma.json").read_text())
    assert written["probe"] == {"stderr": None} and written["uniform"]["levels_used"] == 5
    write_capture_output(tmp_path / "c", caps, {"complete": True}, {"settle_s": NAN})
    assert loads_strict((tmp_path / "c" / "capture_log.json").read_text()) == {"settle_s": None}
    loads_strict((tmp_path / "c" / "manifest.json").read_text())
