"""kamino410 object1 replayed by a strategy (``measure object1 --strategy tolerant``) keeps the
folder's two fringe families and its Gray code (issue 24): both directions come out absolute by
the Gray code, as ``phase`` gives them. Before, the two vertical sets alone were replayed and
the measurement advised adding a Gray code. Skips when ``../shared/realdata`` is absent."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.io.results import read_map_tiff
from tests.conftest import run_cli

pytestmark = pytest.mark.realdata


def test_tolerant_replay_of_object1_keeps_both_families_and_the_gray_code(
    kamino410_object1: Path, tmp_path: Path
) -> None:
    caps, out, ref = kamino410_object1, tmp_path / "out", tmp_path / "phase"  # caps: conftest's
    r = run_cli("measure", str(caps), "--strategy", "tolerant", "--no-previews", "-o", str(out),
                timeout=600)  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert "Gray code" not in r.stdout  # no advice to add what the folder holds
    summary = json.loads((out / "phase_summary.json").read_text())
    fams = {f["orientation"]: f for f in summary["families"]}
    assert set(fams) == {"vertical", "horizontal"}
    assert all(f["order_from"] == "graycode" for f in fams.values())
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["method"] == "tolerant" and metrics["sets_captured"] == 4
    # the same absolute phases as phase --saturated exclude on the folder (every set once)
    r = run_cli("phase", str(caps), "--saturated", "exclude", "--no-previews", "-o", str(ref),
                timeout=600)  # fmt: skip
    assert r.returncode == 0, r.stderr
    for name in ("absolute_phase_vertical.tiff", "absolute_phase_horizontal.tiff"):
        np.testing.assert_array_equal(read_map_tiff(out / name), read_map_tiff(ref / name))
