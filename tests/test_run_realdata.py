"""``hdrfringe run docs/examples/project_kimthyung_sphere.toml``: the kimthyung sphere measured
in one command gives the cloud of the three commands (conftest ``kimthyung_rows``: ``import``
-> ``calibrate-stereo --from`` -> ``measure --stereo-directions v``), and a second run skips
every stage and writes nothing. The example projects read and check against the real data.
Skips when ``../shared/realdata`` is absent.

The second run's time is not asserted (timings are not tests); docs/project_file.md gives the
command and the measured number.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest
import tifffile

from tests.conftest import realdata_path, run_cli

# the reference measurement is conftest's kimthyung_rows, shared with the sphere tests
pytestmark = [pytest.mark.realdata, pytest.mark.xdist_group("sphere-realdata")]

EXAMPLES = Path(__file__).resolve().parents[1] / "docs" / "examples"
KIMTHYUNG = EXAMPLES / "project_kimthyung_sphere.toml"


def _files(out: Path) -> dict[str, tuple[int, int]]:
    """Every file of the run folder but the run summary: size and modification time."""
    return {
        str(p.relative_to(out)): (p.stat().st_size, p.stat().st_mtime_ns)
        for p in sorted(out.rglob("*"))
        if p.is_file() and p.name != "run_summary.json"
    }


@pytest.fixture(scope="module")
def sphere_run(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """The example run twice into one output folder (``-o``: not into build/)."""
    realdata_path("kimthyung_sphere")
    out = tmp_path_factory.mktemp("run_kimthyung") / "out"
    first = run_cli("run", str(KIMTHYUNG), "-o", str(out), timeout=600)
    assert first.returncode == 0, first.stderr
    before = _files(out)
    start = time.perf_counter()
    second = run_cli("run", str(KIMTHYUNG), "-o", str(out))
    seconds = time.perf_counter() - start
    assert second.returncode == 0, second.stderr
    print(f"[realdata] second run of {KIMTHYUNG.name} in process: {seconds:.2f} s")
    return {"out": out, "first": first.stdout, "second": second.stdout, "before": before}


def test_run_reproduces_the_kimthyung_sphere_measurement(
    sphere_run: dict, kimthyung_rows: dict
) -> None:
    """The same points, bit for bit, and the same metrics as the commands typed one by one
    (whose sphere tests/test_sphere_realdata.py fits: radius 51.12 mm)."""
    out = sphere_run["out"]
    for stage in ("import", "calibrate_stereo", "measure"):
        assert f"{stage}: ran (first run" in sphere_run["first"]
    xyz = tifffile.imread(out / "measure" / "xyz.tiff")
    ref = tifffile.imread(kimthyung_rows["out"] / "xyz.tiff")
    assert xyz.shape == ref.shape and np.array_equal(xyz, ref, equal_nan=True)
    metrics = json.loads((out / "measure" / "metrics.json").read_text())
    reference = json.loads((kimthyung_rows["out"] / "metrics.json").read_text())
    assert metrics["stereo"] == reference["stereo"]
    assert metrics["valid_fraction"] == reference["valid_fraction"]


def test_second_run_skips_every_stage_and_writes_nothing(sphere_run: dict) -> None:
    """Nothing changed: each stage says it was skipped, the summary too, and no file but the
    run summary was written."""
    out = sphere_run["out"]
    for stage in ("import", "calibrate_stereo", "measure"):
        assert f"{stage}: skipped (inputs unchanged)" in sphere_run["second"]
    summary = json.loads((out / "run_summary.json").read_text())
    assert [s["status"] for s in summary["stages"]] == ["skipped"] * 3
    assert _files(out) == sphere_run["before"]


@pytest.mark.parametrize("name", sorted(p.name for p in EXAMPLES.glob("project_*.toml")))
def test_example_projects_check_against_the_real_data(name: str) -> None:
    """Every example's paths exist where its ``[paths]`` root points (../shared/realdata)."""
    from hdrfringe.io.project_file import load_project_file

    realdata_path()
    spec = load_project_file(EXAMPLES / name)
    assert spec.output is not None and spec.output.parts[-3:-1] == ("build", "run")
    assert "measure" in spec.tables
