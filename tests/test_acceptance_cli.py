"""``hdrfringe acceptance`` (issue 25): the procedure on the virtual rig at 160 x 120, the offline
path on the captures it kept, strict JSON, and bad input (one line, exit 2, nothing written).

References the code under test did not produce: the virtual artefacts' calibrated sizes (the
scene's closed-form geometry, :mod:`hdrfringe.rig.scenes`) and the rig's true stereo calibration
(its pinhole geometry), written to a file here. The full 23-position run is the benchmark
(``benchmarks/bench_acceptance.py``), not a test.

Tolerance on PS and SD, derived: the camera's pixel covers ``p = 2 d tan(fov/2) / W`` mm at the
artefact (d its distance, computed here from the true calibration: about 2.4 mm at 160 px). The
camera blur (0.5 px) mixes each rim pixel of a ball with the base far below it; the sphere's
band keeps rim points whose error is below a few mm, and a fit through them moves the diameter
and the centres by a fraction of a pixel: we allow ``p / 2`` (about 1.2 mm). The noise alone
(the predicted std, checked to be reported) is far smaller. Broken variants rejected by the
same tolerance: a calibration whose baseline is 1 % too long (every length 1 % too long: SD
+1.9 mm on the 187 mm bar) and an acceptance file whose sphere is the ball bar's (45 mm for the
68 mm sphere: PS +23 mm).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.conftest import run_cli

SIZE = (160, 120)
POSITIONS = "sphere:9,ball_bar:6,plane:1"


def _write_calibration(path: Path, scale: float = 1.0) -> Any:
    from hdrfringe.core.stereo import StereoCalibration
    from hdrfringe.io.stereo_file import save_stereo_calibration
    from hdrfringe.rig.board_poses import calibration_rig
    from hdrfringe.rig.scenes import white_plate

    true = calibration_rig(white_plate(), camera_size=SIZE).stereo_calibration()
    cal = StereoCalibration(
        true.camera, true.projector, true.rotation, np.asarray(true.translation_mm) * scale
    )
    save_stereo_calibration(path, cal)
    return true


def _toml(path: Path, sphere: float, ball: float, distance: float, plane: tuple) -> Path:
    path.write_text(
        "[mpe]\npf = 3.0\nps = 0.5\nsd = 0.6\nf = 4.0\n"
        f"[sphere]\ndiameter = {sphere}\n"
        f"[ball_bar]\ndistance = {distance}\ndiameters = [{ball}, {ball}]\n"
        f"[plane]\nlength = {plane[0]}\nwidth = {plane[1]}\n",
        encoding="utf-8",
    )
    return path


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """One sim run of three positions with the true calibration, captures kept."""
    tmp = tmp_path_factory.mktemp("acceptance")
    true = _write_calibration(tmp / "true.h5")
    _write_calibration(tmp / "scaled.h5", 1.01)
    out = tmp / "sim"
    res = run_cli(
        "acceptance",
        "--rig",
        "sim",
        "-o",
        str(out),
        "--size",
        f"{SIZE[0]}x{SIZE[1]}",
        "--positions",
        POSITIONS,
        "-c",
        str(tmp / "true.h5"),
        "--keep-captures",
    )
    assert res.returncode == 0, res.stderr
    text = (out / "acceptance.json").read_text(encoding="utf-8")
    return {"tmp": tmp, "out": out, "json": json.loads(text), "text": text, "true": true}


def _pixel_mm(true: Any, depth_mm: float) -> float:
    """The camera pixel's footprint at a depth, from the true calibration."""
    return float(depth_mm / true.camera.matrix[0, 0])


def _values(doc: dict[str, Any]) -> dict[str, dict[str, float]]:
    return {p["label"]: p["values"] for p in doc["positions"]}


def test_sim_matches_the_ground_truth_within_the_derived_tolerance(run: dict[str, Any]) -> None:
    doc, true = run["json"], run["true"]
    pos = {p["label"]: p for p in doc["positions"]}
    assert set(pos) == {"sphere_09", "ball_bar_06", "plane_01"}
    depth = pos["sphere_09"]["details"]["centre_mm"][2]
    tol = _pixel_mm(true, depth) / 2
    assert 0.8 < tol < 1.6  # about 1.2 mm at 160 px
    ps, sd = pos["sphere_09"]["values"]["PS"], pos["ball_bar_06"]["values"]["SD"]
    assert abs(ps) < tol and abs(sd) < tol
    # the centre against the truth (camera frame), and the predicted noise std is reported
    assert pos["sphere_09"]["details"]["error_vs_truth_mm"]["centre_mm"] < tol
    assert 0 < pos["sphere_09"]["details"]["predicted_std_mm"]["PS"] < tol
    assert 0 < pos["ball_bar_06"]["details"]["predicted_std_mm"]["SD"] < tol
    # a flat plane: F is the noise's range, a few mm at this size, finite and positive
    assert 0 < pos["plane_01"]["values"]["F"] < 4 * tol
    # the verdict against the run's MPEs (SIM_MPES) is in the summary
    summary = doc["strategies"]["conventional"]
    assert summary["images"]["total"] == 36 and len(summary["records"]) == 4
    assert (run["out"] / "quantities.png").is_file()
    assert (run["out"] / "residuals" / "conventional" / "sphere_09.png").is_file()
    # broken variant 1: a calibration 1 % too long shows in SD beyond the tolerance
    out = run["tmp"] / "scaled"
    res = run_cli(
        "acceptance",
        "--rig",
        "sim",
        "-o",
        str(out),
        "--size",
        f"{SIZE[0]}x{SIZE[1]}",
        "--positions",
        "ball_bar:6",
        "-c",
        str(run["tmp"] / "scaled.h5"),
    )
    assert res.returncode == 0, res.stderr
    scaled = json.loads((out / "acceptance.json").read_text())["positions"][0]["values"]["SD"]
    assert abs(scaled) > tol and abs(scaled - sd - 1.87) < 0.2


def test_strict_json(run: dict[str, Any]) -> None:
    def refuse(name: str) -> None:
        raise ValueError(name)

    json.loads(run["text"], parse_constant=refuse)  # no NaN, Infinity
    json.dumps(run["json"], allow_nan=False)


def test_offline_equals_sim_on_the_kept_captures(run: dict[str, Any]) -> None:
    tmp, doc = run["tmp"], run["json"]
    folders = sorted((run["out"] / "captures" / "conventional").iterdir())
    assert [f.name for f in folders] == ["ball_bar_06", "plane_01", "sphere_09"]
    plan = doc["artefacts"]
    toml = _toml(
        tmp / "a.toml",
        plan["sphere"]["diameter_mm"],
        plan["ball_bar"]["diameters_mm"][0],
        plan["ball_bar"]["distance_mm"],
        (plan["plane"]["length_mm"], plan["plane"]["width_mm"]),
    )
    out = tmp / "offline"
    res = run_cli(
        "acceptance",
        *map(str, folders),
        "-c",
        str(tmp / "true.h5"),
        "--file",
        str(toml),
        "-o",
        str(out),
    )
    assert res.returncode == 0, res.stderr
    offline = json.loads((out / "acceptance.json").read_text())
    sim, off = _values(doc), _values(offline)
    assert set(sim) == set(off)
    for label, values in sim.items():
        for q, v in values.items():
            assert math.isclose(off[label][q], v, rel_tol=0, abs_tol=1e-9), (label, q)
    # broken variant 2: a calibrated diameter 3 % (2 mm) off: PS beyond the tolerance
    true_d = plan["sphere"]["diameter_mm"]
    wrong = _toml(tmp / "wrong.toml", 1.03 * true_d, 45.0, 187.0, (227.0, 68.0))
    res = run_cli(
        "acceptance",
        str(folders[2]),
        "-c",
        str(tmp / "true.h5"),
        "--file",
        str(wrong),
        "-o",
        str(tmp / "wrong"),
    )
    assert res.returncode == 0, res.stderr
    ps = json.loads((tmp / "wrong" / "acceptance.json").read_text())["positions"][0]["values"]
    tol = _pixel_mm(run["true"], doc["positions"][0]["details"]["centre_mm"][2]) / 2
    assert abs(ps["PS"]) > tol and math.isclose(ps["PS"], sim["sphere_09"]["PS"] - 0.03 * true_d)


def _bad(tmp: Path, *args: str) -> str:
    out = tmp / "bad-out"
    res = run_cli("acceptance", *args, "-o", str(out))
    assert res.returncode == 2, (args, res.stdout, res.stderr)
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in res.stderr, res.stderr
    assert not out.exists()
    return lines[0]


def test_bad_input_is_one_line_exit_2_nothing_written(run: dict[str, Any]) -> None:
    tmp = run["tmp"]
    sim = ("--rig", "sim", "--size", "160x120", "-c", str(tmp / "true.h5"))
    assert "the plan has sphere positions 1..10" in _bad(tmp, *sim, "--positions", "sphere:11")
    assert "unknown artefact 'cube'" in _bad(tmp, *sim, "--positions", "cube:1")
    assert "unknown" in _bad(tmp, *sim, "--strategy", "best")
    # a calibration that does not fit the camera
    assert "does not fit --size 96x72" in _bad(
        tmp, "--rig", "sim", "--size", "96x72", "-c", str(tmp / "true.h5")
    )
    # MPE file errors
    bad = tmp / "bad.toml"
    bad.write_text("[mpe]\npf = -1\nps = 0.1\nsd = 0.1\nf = 0.1\n[sphere]\ndiameter = 50\n")
    assert "mpe.pf" in _bad(tmp, *sim, "--file", str(bad))
    # missing positions: the file has no ball bar
    only = tmp / "only.toml"
    only.write_text("[mpe]\npf = 1\nps = 0.1\nsd = 0.1\nf = 0.1\n[sphere]\ndiameter = 68\n")
    assert "no [ball_bar]" in _bad(tmp, *sim, "--file", str(only), "--positions", "ball_bar:1")
    # a folder without its sidecar; no folders at all
    folder = run["out"] / "captures" / "conventional" / "sphere_09"
    plain = tmp / "plain"
    plain.mkdir(exist_ok=True)
    (plain / "manifest.json").write_text((folder / "manifest.json").read_text())
    line = _bad(tmp, str(plain), "-c", str(tmp / "true.h5"), "--file", str(only))
    assert "no acceptance_position.json" in line
    assert "need --calibration" in _bad(tmp)


def test_artefact_not_found_is_a_failed_row_with_its_reason(run: dict[str, Any]) -> None:
    """An artefact not found (the sphere searched 500 mm away from where it stands) is an
    unevaluated row: values None, the reason in the note, the acceptance failed."""
    tmp = run["tmp"]
    folder = run["out"] / "captures" / "conventional" / "sphere_09"
    moved = tmp / "moved"
    if not moved.exists():
        import shutil

        shutil.copytree(folder, moved)
        side = json.loads((moved / "acceptance_position.json").read_text())
        side["expected"]["centre_mm"] = [500.0, 500.0, 600.0]  # far from the sphere
        (moved / "acceptance_position.json").write_text(json.dumps(side))
    toml = _toml(tmp / "nf.toml", 68.0, 45.0, 187.0, (227.0, 68.0))
    res = run_cli(
        "acceptance",
        str(moved),
        "-c",
        str(tmp / "true.h5"),
        "--file",
        str(toml),
        "-o",
        str(tmp / "nf"),
    )
    assert res.returncode == 0, res.stderr
    doc = json.loads((tmp / "nf" / "acceptance.json").read_text())
    row = doc["positions"][0]
    assert row["values"] == {"PF": None, "PS": None} and "not found" in row["note"]
    assert doc["strategies"]["conventional"]["all_passed"] is False


# --- --rig hardware on the fake projector and camera of tests/test_hardware_rig.py -------------


def _hardware_inputs(tmp: Path) -> tuple[Path, Path]:
    from hdrfringe.io.stereo_file import save_stereo_calibration
    from hdrfringe.rig.simulated import RigGeometry
    from tests.test_hardware_rig import H, W

    cal = tmp / "fake.h5"
    if not cal.exists():
        save_stereo_calibration(cal, RigGeometry().stereo_calibration((W // 2, H // 2), (W, H)))
    toml = _toml(tmp / "hw.toml", 68.0, 45.0, 187.0, (227.0, 68.0))
    return cal, toml


def _invoke(args: list[str], stdin: str = "") -> Any:
    from typer.testing import CliRunner

    from hdrfringe.cli import app

    return CliRunner().invoke(app, ["acceptance", *args], input=stdin)


#: The fake rig's grabs when it opens, and per position: 7 for the new reference image and one
#: per frame of the 12 (3 pitches x 4 steps, conventional).
PER_POSITION = 7 + 12


def test_hardware_prompts_per_position_and_keeps_complete_ones(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """q at the third prompt: the two complete positions are written, each a capture folder
    with its sidecar, evaluated (a plane: the fake camera's cloud is no artefact; what it
    measures is not checked). Ctrl-C mid position 2: position 1 kept, exit 2."""
    from hdrfringe.io.captures import read_capture_folder
    from hdrfringe.tasks import acceptance as task
    from tests.test_capture_poses import fake_rig
    from tests.test_hardware_rig import OPEN_GRABS, InterruptingCamera

    cal, toml = _hardware_inputs(tmp_path)
    common = [
        "--rig",
        "hardware",
        "--projector",
        "screen:0",
        "--camera",
        "fake:0",
        "-c",
        str(cal),
        "--file",
        str(toml),
        "--positions",
        "plane:1-3",
    ]
    monkeypatch.setattr(task, "_acceptance_rig", fake_rig())
    out = tmp_path / "live"
    r = _invoke([*common, "-o", str(out)], stdin="\n\nq\n")
    assert r.exit_code == 0, r.output
    assert "position 3/3 (plane_03): place the artefact" in r.output
    doc = json.loads((out / "acceptance.json").read_text())
    assert [p["label"] for p in doc["positions"]] == ["plane_01", "plane_02"]
    assert doc["setup"]["complete"] is False and doc["setup"]["stopped"] == "finished with q"
    folders = sorted((out / "captures" / "conventional").iterdir())
    assert [f.name for f in folders] == ["plane_01", "plane_02"]
    assert len(read_capture_folder(folders[1]).frames) == 12
    side = json.loads((folders[0] / "acceptance_position.json").read_text())
    assert side["kind"] == "plane" and side["images"] == 12
    # Ctrl-C in position 2 (the camera's gain as FakeCamera's: the fringes unclipped)
    class Interrupting(InterruptingCamera):
        def __init__(self, projector: Any, at: int) -> None:
            super().__init__(projector, at)
            self.gain = 1.0

    at = OPEN_GRABS + PER_POSITION + 5
    monkeypatch.setattr(task, "_acceptance_rig", fake_rig(Interrupting, at=at))
    r = _invoke([*common, "--interval", "0", "-o", str(tmp_path / "stopped")])
    assert r.exit_code == 2
    assert "holds the 1 complete positions" in " ".join(r.stderr.split())
    names = [p.name for p in (tmp_path / "stopped" / "captures" / "conventional").iterdir()]
    assert names == ["plane_01"]
    # q at the first prompt: nothing written
    monkeypatch.setattr(task, "_acceptance_rig", fake_rig())
    r = _invoke([*common, "-o", str(tmp_path / "none")], stdin="q\n")
    assert r.exit_code == 2 and "before the first position; nothing written" in r.stderr
    assert not (tmp_path / "none").exists()
