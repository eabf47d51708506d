"""``measure`` on a folder written by ``capture`` replays it with the method and strategy
options ``capture_log.json`` records (issue 24, item 5): before, without ``--strategy`` it decoded
every MIGL set of the sweep separately. An explicit equal ``--strategy`` is accepted, another one
is a one-line error (exit 2).

The loop rig (an Xvfb projector window and the loop camera, docs/hardware.md) captures with
``--strategy lpa --step 50``; the reference is ``measure FOLDER --strategy lpa --step 50``, the
replay the user had to type before.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.io.results import read_map_tiff
from tests.conftest import run_cli, xvfb_display
from tests.test_measure_hardware import FRINGES, SCREEN, loop_camera

pytestmark = pytest.mark.xdist_group("xvfb")


@pytest.fixture(scope="module")
def captured(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """``capture --strategy lpa --step 50`` on the loop rig (no rig configuration file)."""
    caps = tmp_path_factory.mktemp("log") / "caps"
    with xvfb_display(*SCREEN) as display:
        r = run_cli(
            "capture", "--projector", f"screen:0@{display}", "--camera", loop_camera(display),
            "--settle", "0", "--strategy", "lpa", "--step", "50", *FRINGES, "-o", str(caps),
            timeout=600,
        )  # fmt: skip
        assert r.returncode == 0, r.stderr
    yield caps


def test_capture_log_records_the_method_and_its_options(captured: Path) -> None:
    log = json.loads((captured / "capture_log.json").read_text())
    assert log["method"] == "lpa" and log["strategy_options"] == {"--step": 50.0}
    manifest = json.loads((captured / "manifest.json").read_text())
    assert manifest["capture"]["strategy_options"] == {"--step": 50.0}


def test_measure_replays_the_logged_strategy(captured: Path, tmp_path: Path) -> None:
    """Without --strategy: the logged lpa with --step 50, the same maps and MIGLs as the explicit
    replay; with --strategy lpa (equal): the same again. Rejects a measure that decodes every
    set of the sweep (no strategy block, one map per MIGL set) or that drops the logged step
    (LPA's default step walks other MIGLs, which the folder does not hold)."""
    auto, explicit, equal = tmp_path / "auto", tmp_path / "explicit", tmp_path / "equal"
    r = run_cli("measure", str(captured), "--no-previews", "-o", str(auto))
    assert r.returncode == 0, r.stderr
    assert f"{captured}: captured with --strategy lpa (capture_log.json), replayed" in r.stdout
    r = run_cli("measure", str(captured), "--strategy", "lpa", "--step", "50", "--no-previews",
                "-o", str(explicit))  # fmt: skip
    assert r.returncode == 0, r.stderr
    r = run_cli("measure", str(captured), "--strategy", "lpa", "--no-previews", "-o", str(equal))
    assert r.returncode == 0, r.stderr
    maps = sorted(p.name for p in explicit.glob("*.tiff"))
    assert "absolute_phase_vertical.tiff" in maps
    for other in (auto, equal):
        assert sorted(p.name for p in other.glob("*.tiff")) == maps
        for name in maps:
            np.testing.assert_array_equal(
                read_map_tiff(other / name), read_map_tiff(explicit / name), err_msg=name
            )
        a = json.loads((other / "metrics.json").read_text())
        b = json.loads((explicit / "metrics.json").read_text())
        assert a["method"] == b["method"] == "lpa" and a["migls"] == b["migls"]
        assert all(len(m) > 1 for m in a["migls"])


def test_measure_refuses_another_method(captured: Path, tmp_path: Path) -> None:
    out = tmp_path / "never"
    r = run_cli("measure", str(captured), "--strategy", "dpa", "-o", str(out))
    assert r.returncode == 2
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in r.stderr
    assert "was captured with --strategy lpa (capture_log.json), not dpa" in lines[0]
    assert "drop --strategy or give --strategy lpa" in lines[0]
    assert not out.exists()


def test_crafted_logs(tmp_path: Path) -> None:
    """A folder written by simulate with a crafted log: no "method" (a fixed program such as
    capture-gamma) measures the folder as it is; an unreadable log is one line (exit 2)."""
    folder = tmp_path / "caps"
    r = run_cli("simulate", "white_plate", "-o", str(folder), "--pitch", "8", "--steps", "3")
    assert r.returncode == 0, r.stderr
    (folder / "capture_log.json").write_text(json.dumps({"program": "gamma", "frames": []}))
    r = run_cli("measure", str(folder), "--no-previews", "-o", str(tmp_path / "plain"))
    assert r.returncode == 0, r.stderr
    metrics = json.loads((tmp_path / "plain" / "metrics.json").read_text())
    assert "method" not in metrics and "replayed" not in r.stdout
    (folder / "capture_log.json").write_text("{not json")
    r = run_cli("measure", str(folder), "-o", str(tmp_path / "never"))
    assert r.returncode == 2 and "not a readable capture log" in r.stderr
    assert not (tmp_path / "never").exists()
